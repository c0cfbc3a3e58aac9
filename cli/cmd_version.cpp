// `texdefrag --version`: what this build is (version, source revision, compiler, model formats and
// optional features compiled in), then where it runs from.
#include "texdefrag/util/paths.h"

#include "commands.h"

namespace texdefrag::cli {

std::string build_info();  // generated: cmake/build_info.cmake

std::string version_text() {
  std::string s = build_info();
  std::string root;
  try {
    root = install_root();
  } catch (const std::exception& e) {
    root = e.what();
  }
  s += "prefix: " + root + " (stage modules in lib/texdefrag/plugins, configurations in share/texdefrag/configs)";
  return s;
}

}  // namespace texdefrag::cli
