// Detection time on a ~100k-face noisy building in 2x2-quad charts (the speed target of issue 4:
// well under a second). Topology and charts are built once outside the timed loop.
#include "common/test_meshes.h"
#include "texdefrag/stage/registry.h"

#include <benchmark/benchmark.h>

using namespace texdefrag;

static void run(benchmark::State& state, const char* name, const json& overrides = json::object()) {
  const auto c = detectors::testmesh::building_case(static_cast<int>(state.range(0)));
  Registry& reg = Registry::instance();
  reg.load_plugins();
  auto stage = reg.create(name);
  auto* det = dynamic_cast<Detector*>(stage.get());
  det->set_options(default_options(*reg.find(name), overrides));
  const Topology topo = build_topology(c.mesh);
  const ChartSet charts = build_charts(c.mesh, topo);
  for (auto _ : state) {
    json report = json::object();
    StageContext ctx;
    ctx.mesh = &c.mesh;
    ctx.topology = &topo;
    ctx.input_charts = &charts;
    ctx.report = &report;
    det->detect(ctx);
    benchmark::DoNotOptimize(ctx.regions.num_regions);
    state.counters["regions"] = ctx.regions.num_regions;
  }
  state.counters["faces"] = static_cast<double>(c.mesh.faces.size());
}
static void BM_RegionGrowing(benchmark::State& s) { run(s, "detectors.region_growing"); }
static void BM_RegionGrowingNoGrouping(benchmark::State& s) {
  // The refinements before coplanar grouping and curved surfaces (docs/detectors.md, refinements 9-10).
  run(s, "detectors.region_growing", {{"coplanar_grouping", false}, {"curved_surfaces", false}});
}
static void BM_AngleGrowing(benchmark::State& s) { run(s, "detectors.angle_growing"); }
BENCHMARK(BM_RegionGrowing)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RegionGrowingNoGrouping)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AngleGrowing)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
