// Transparent huge pages for the heap (docs/speed.md, "Page faults"): re-executes the program once
// with glibc's malloc tunable `glibc.malloc.hugetlb=1`, so malloc asks the kernel for huge pages
// (madvise) on its large blocks. On this kind of machine (a virtual machine whose page faults cost
// ~10 microseconds) the 4 KB page faults of the images, canvases and solver buffers were 10-20% of a
// run's CPU time: the 100k-face factory took 89,900 minor faults and 5.9 CPU s, with the tunable
// 18,000 and 4.9 s. Outputs do not change (only where memory comes from).
//
// The tunable is read by the dynamic loader at start, so it cannot be set from inside a running
// process: main() calls this first, and for `run` and `bench` the program starts again with it set
// (about 0.05 CPU s: every library is loaded twice). The environment the child processes of the run
// see is restored to the user's.
#include "commands.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace texdefrag::cli {
namespace {
constexpr const char* kTunable = "glibc.malloc.hugetlb=1";
/// Set by the first start to the user's GLIBC_TUNABLES ("-" when there was none): marks the second.
constexpr const char* kMarker = "TEXDEFRAG_GLIBC_TUNABLES";

/// The sub-command is one that processes models in this process (`run`, `bench`): the others are
/// short, and a restart (loading every library twice, about 0.05 CPU s) would cost more than it gains.
bool heavy_command(char** argv) {
  for (char** a = argv + 1; *a; ++a)
    if ((*a)[0] != '-') return std::string(*a) == "run" || std::string(*a) == "bench";
  return false;
}

/// The kernel gives huge pages on request: /sys/kernel/mm/transparent_hugepage/enabled is
/// "[madvise]" (with "[always]" every large mapping has them already, with "[never]" none can).
bool huge_pages_on_request() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  return std::getline(in, line) && line.find("[madvise]") != std::string::npos;
}
}  // namespace

void use_huge_pages(char** argv) {
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
  if (const char* original = std::getenv(kMarker)) {
    // The second start: the loader has read the tunable; children get the user's environment.
    const std::string value = original;
    if (value == "-") unsetenv("GLIBC_TUNABLES");
    else setenv("GLIBC_TUNABLES", value.c_str(), 1);
    unsetenv(kMarker);
    return;
  }
  const char* off = std::getenv("TEXDEFRAG_HUGE_PAGES");
  if ((off && std::string(off) == "0") || !heavy_command(argv)) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string user = tunables ? tunables : "";
  if (user.find("glibc.malloc.hugetlb") != std::string::npos || !huge_pages_on_request()) return;
  setenv(kMarker, tunables ? user.c_str() : "-", 1);
  setenv("GLIBC_TUNABLES", (user.empty() ? std::string(kTunable) : user + ":" + kTunable).c_str(), 1);
  execv("/proc/self/exe", argv);
  // note: no /proc (or exec refused): run as started, with the user's environment.
  if (tunables) setenv("GLIBC_TUNABLES", user.c_str(), 1);
  else unsetenv("GLIBC_TUNABLES");
  unsetenv(kMarker);
#else
  (void)argv;
#endif
}
}  // namespace texdefrag::cli
