// Threads per stage (issue 16): one whole run of a configuration on a model with --threads 1 and
// --threads 2, each stage's time from the run report as a counter (seconds). The parallel steps are
// texture.resample and write (docs/framework.md, "Threads"); the others stay on one thread and
// show the noise. Default: configs/best.json on the real tile t016_L19 (46k faces, 24 pages);
// BENCH_THREADS_MODEL and BENCH_THREADS_CONFIG choose others (e.g. a `texdefrag synth` factory).
// Exits 0 with a message when the model is absent. Numbers: docs/bench.md, "Speed".
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/util/parallel.h"
#include "texdefrag/util/paths.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;

namespace {

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : fallback;
}

const std::string& model() {
  static const std::string path = env_or(
      "BENCH_THREADS_MODEL", std::string(texdefrag::shared_data_dir()) + "/contextcapture/prod5_t016_L19/t016_L19.obj");
  return path;
}

void BM_Run(benchmark::State& state) {
  using namespace texdefrag;
  const int threads = static_cast<int>(state.range(0));
  const PipelineConfig cfg = load_config(resolve_config(env_or("BENCH_THREADS_CONFIG", "best")));
  const fs::path out = fs::temp_directory_path() / ("bench_threads_" + std::to_string(threads));
  set_thread_count(threads);
  json report;
  for (auto _ : state) {
    fs::remove_all(out);
    RunOptions ro;
    ro.input = model();
    ro.output_dir = out.string();
    report = run_pipeline(cfg, ro);
  }
  set_thread_count(0);
  fs::remove_all(out);
  for (const auto& [name, node] : report["stages"].items())
    state.counters[name + "_s"] = node["time_s"].get<double>();
  state.counters["total_s"] = report["total_time_s"].get<double>();
  state.counters["peak_mb"] = static_cast<double>(report["peak_rss_bytes"].get<size_t>()) / 1048576.0;
}

}  // namespace

int main(int argc, char** argv) {
  std::error_code ec;
  if (!fs::exists(model(), ec)) {
    std::printf("bench_threads: skipped, %s is absent\n", model().c_str());
    return 0;
  }
  benchmark::RegisterBenchmark("BM_Run", BM_Run)->Arg(1)->Arg(2)->Iterations(1)->Repetitions(3)
      ->Unit(benchmark::kSecond)->UseRealTime();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
