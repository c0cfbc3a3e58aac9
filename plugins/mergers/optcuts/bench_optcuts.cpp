// Benchmark: mergers.optcuts / mergers.arap on the largest real tile (46k faces) and on a synthetic
// fragmented grid of 50k faces. Run: bench_mergers_optcuts [--benchmark_filter=...]
#include "arap_solver.h"
#include "merge_engine.h"
#include "sd_newton.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <benchmark/benchmark.h>

namespace texdefrag::merge {
namespace {

template <class Solver>
void run_on(benchmark::State& state, const TexturedMesh& mesh, Priority prio) {
  const Topology topo = build_topology(mesh);
  const ChartSet cs = build_charts(mesh, topo);
  MergeReport r;
  for (auto _ : state) {
    Atlas at = cs.atlas;
    Solver solver;
    MergeOptions o;
    o.priority = prio;
    r = run_merges(mesh, topo, at, {}, o, solver, {});
    benchmark::DoNotOptimize(at.num_charts);
  }
  state.counters["faces"] = static_cast<double>(mesh.faces.size());
  state.counters["charts_in"] = static_cast<double>(r.charts_in);
  state.counters["charts_out"] = static_cast<double>(r.charts_out);
  state.counters["E"] = r.distortion_out;
  state.counters["opt_s"] = r.optimisation_seconds;
  state.counters["check_s"] = r.check_seconds;
}

const TexturedMesh& real_tile() {
  static const TexturedMesh m = [] {
    const std::string p = texdefrag::testing::shared_data("contextcapture/prod5_t016_L19/t016_L19.obj");
    return p.empty() ? TexturedMesh{} : read_obj(p);
  }();
  return m;
}

void BM_OptCutsRealTile(benchmark::State& s) {
  if (real_tile().faces.empty()) return s.SkipWithError("shared data absent");
  run_on<SdNewtonSolver>(s, real_tile(), Priority::Planarity);
}
void BM_ArapMMethodRealTile(benchmark::State& s) {
  if (real_tile().faces.empty()) return s.SkipWithError("shared data absent");
  run_on<ArapSolver>(s, real_tile(), Priority::MMethod);
}
void BM_OptCutsGrid50k(benchmark::State& s) {
  static const TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(160, 157, 4096, "unused.png");
  run_on<SdNewtonSolver>(s, m, Priority::Planarity);
}

BENCHMARK(BM_OptCutsRealTile)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_ArapMMethodRealTile)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_OptCutsGrid50k)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace texdefrag::merge

BENCHMARK_MAIN();
