// libFuzzer target for the JSON configuration parser (docs/framework.md; docs/io.md "Fuzzing").
//
// Each input is written as a configuration file and loaded with every stage module registered.
// An input whose first line starts with "#set " carries overrides instead: each such line is one
// `--set` string and the rest is the configuration. Properties checked on every input:
// - load_config either succeeds or throws ConfigError (anything else, a crash, a leak or undefined
//   behaviour is a finding: the target is built with AddressSanitizer and UBSan);
// - a configuration that loads is a fixed point: its effective configuration parses again, without
//   overrides, to the same effective configuration.
// Build: CXX=clang++ cmake -DTEXDEFRAG_FUZZ=ON ...; run: fuzz_config configs configs/bad.
#include "texdefrag/pipeline/pipeline.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_config: %s\n", what);
  std::abort();
}

const fs::path& work_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("texdefrag-fuzz-config-" + std::to_string(::getpid()));
    fs::create_directories(d);
    Registry::instance().load_plugins();
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> sets;
  while (text.rfind("#set ", 0) == 0) {
    const size_t nl = text.find('\n');
    sets.push_back(text.substr(5, nl == std::string::npos ? std::string::npos : nl - 5));
    text = nl == std::string::npos ? "" : text.substr(nl + 1);
  }
  const fs::path path = work_dir() / "config.json";
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << text;
  }
  PipelineConfig cfg;
  try {
    cfg = load_config(path.string(), sets);
  } catch (const ConfigError&) {
    return 0;
  }
  try {
    const PipelineConfig again = parse_config(cfg.effective, "<effective>");
    if (again.effective != cfg.effective) finding("the effective configuration is not a fixed point");
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    finding("the effective configuration of a valid configuration does not parse");
  }
  return 0;
}
