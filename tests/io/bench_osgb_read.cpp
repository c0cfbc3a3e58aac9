// Reading cost of the OSGB reader on the real osgb_prod5 production (31 files, 153,401 positions,
// JPEG pages embedded): BM_ReadOsgb reads every file with OsgbFormat::read. Counters per file:
// `cpu_s_per_file` (this process) and `child_cpu_s_per_file` (the bounded reader's child
// processes, docs/io.md "OSGB: bounded reading"; getrusage(RUSAGE_CHILDREN), which Google
// Benchmark's CPU column does not include), the minor page faults of each, and the largest resident
// size of a child (`child_max_rss_mib`, against the limit of osgb_read_limits). Exits 0 with a message when ../shared/data is absent.
#include "texdefrag/io/osgb.h"
#include "texdefrag/util/paths.h"

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace {

const std::string& production() {
  static const std::string path = std::string(texdefrag::shared_data_dir()) + "/contextcapture/osgb_prod5";
  return path;
}

std::vector<std::string> files() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(production()))
    if (e.path().extension() == ".osgb") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

double minor_faults(int who) {
  rusage u{};
  getrusage(who, &u);
  return static_cast<double>(u.ru_minflt);
}

double cpu_s(int who) {
  rusage u{};
  getrusage(who, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

void BM_ReadOsgb(benchmark::State& state) {
  const std::vector<std::string> paths = files();
  size_t faces = 0, reads = 0;
  const double self0 = cpu_s(RUSAGE_SELF), child0 = cpu_s(RUSAGE_CHILDREN);
  const double faults0 = minor_faults(RUSAGE_SELF), child_faults0 = minor_faults(RUSAGE_CHILDREN);
  for (auto _ : state) {
    for (const std::string& p : paths) {
      faces += texdefrag::OsgbFormat().read(p).mesh.faces.size();
      ++reads;
    }
    benchmark::DoNotOptimize(faces);
  }
  const double n = static_cast<double>(std::max<size_t>(reads, 1));
  state.counters["files"] = static_cast<double>(paths.size());
  state.counters["cpu_s_per_file"] = (cpu_s(RUSAGE_SELF) - self0) / n;
  state.counters["child_cpu_s_per_file"] = (cpu_s(RUSAGE_CHILDREN) - child0) / n;
  state.counters["faults_per_file"] = (minor_faults(RUSAGE_SELF) - faults0) / n;
  state.counters["child_faults_per_file"] = (minor_faults(RUSAGE_CHILDREN) - child_faults0) / n;
  rusage u{};
  getrusage(RUSAGE_CHILDREN, &u);
  state.counters["child_max_rss_mib"] = static_cast<double>(u.ru_maxrss) / 1024.0;
}

}  // namespace

int main(int argc, char** argv) {
  std::error_code ec;
  if (!std::filesystem::exists(production(), ec)) {
    std::printf("bench_osgb_read: skipped, %s is absent\n", production().c_str());
    return 0;
  }
  benchmark::RegisterBenchmark("BM_ReadOsgb/osgb_prod5", BM_ReadOsgb)->Unit(benchmark::kMillisecond)->MinTime(5.0);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
