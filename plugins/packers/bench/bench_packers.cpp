// bench_packers: packing time of each packer on 10,000 (and 100,000) synthetic charts (the size of a merged
// city tile's atlas: 30% facade/roof rectangles of 40-300 texels, the rest 3-24 texel fragments).
// The target: 10,000 charts packed well under a second.
#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/stage/registry.h"

#include <benchmark/benchmark.h>

#include <random>

using namespace texdefrag;

namespace {

struct Fixture {
  TexturedMesh mesh;
  Topology topo;
  ChartSet charts;
};

const Fixture& fixture(int count) {
  static std::map<int, Fixture> cache;
  auto it = cache.find(count);
  if (it != cache.end()) return it->second;
  Fixture& fx = cache[count];
  const int page = 8192;
  fx.mesh.materials.push_back(Material{"page0", {}, "page0.png", ""});
  fx.mesh.pages.push_back(Page{"page0", "page0.png", page, page});
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> big(40, 300), small(3, 24), pos(0, page - 320);
  std::uniform_real_distribution<double> u(0, 1);
  for (int c = 0; c < count; ++c) {
    const Vec2 o(pos(rng), pos(rng));
    std::vector<Vec2> poly;
    if (u(rng) < 0.3) {
      const double a = big(rng), b = big(rng) * 0.6;
      poly = {{0, 0}, {a, 0}, {a, b}, {0, b}};
    } else {
      const double a = small(rng), b = small(rng);
      if (u(rng) < 0.5) poly = {{0, 0}, {a, 0}, {a, b}, {0, b}};
      else poly = {{0, 0}, {a, 0}, {0, b}};
    }
    const int v0 = static_cast<int>(fx.mesh.positions.size());
    for (const Vec2& q : poly) {
      fx.mesh.positions.emplace_back(q.x(), q.y(), static_cast<double>(c));
      fx.mesh.texcoords.push_back((q + o) / page);
    }
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      Face f;
      f.v = {v0, v0 + static_cast<int>(k), v0 + static_cast<int>(k) + 1};
      f.vt = f.v;
      f.material = 0;
      f.page = 0;
      fx.mesh.faces.push_back(f);
    }
  }
  fx.topo = build_topology(fx.mesh);
  fx.charts = build_charts(fx.mesh, fx.topo);
  return fx;
}

void BM_Pack(benchmark::State& state, const std::string& name, const json& options = json::object()) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  const StageInfo* info = reg.find(name);
  if (!info) {
    state.SkipWithError((name + " not built").c_str());
    return;
  }
  const Fixture& fx = fixture(static_cast<int>(state.range(0)));
  std::unique_ptr<Stage> st = reg.create(name);
  st->set_options(default_options(*info, options));
  auto* packer = dynamic_cast<Packer*>(st.get());
  double eff = 0;
  for (auto _ : state) {
    state.PauseTiming();
    StageContext ctx;
    json report = json::object();
    ctx.mesh = &fx.mesh;
    ctx.topology = &fx.topo;
    ctx.input_charts = &fx.charts;
    ctx.atlas = fx.charts.atlas;
    ctx.report = &report;
    ctx.progress = [](const std::string&, double) { return true; };
    state.ResumeTiming();
    packer->pack(ctx);
    benchmark::DoNotOptimize(ctx.layout.wedge_uv.data());
    eff = report.value("packing_efficiency", 0.0);
  }
  state.counters["charts"] = static_cast<double>(fx.charts.atlas.num_charts);
  state.counters["efficiency"] = eff;
}

}  // namespace

// note: 100,000 charts (issue 16, time growth at scale): the default's tail is over tail_max_charts
// there and is dropped on the horizon.
BENCHMARK_CAPTURE(BM_Pack, square_tetris, std::string("packers.square_tetris"))->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Pack, square_tetris_tail0, std::string("packers.square_tetris"), json{{"tail_side", 0}})
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Pack, square_tetris_tail256, std::string("packers.square_tetris"),
                  json{{"tail_side", 256}, {"tail_max_charts", 0}})
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond);
// note: the default skips the outline tail beyond 1500 tail charts; this is its cost without the limit.
BENCHMARK_CAPTURE(BM_Pack, square_tetris_tail512_unlimited, std::string("packers.square_tetris"),
                  json{{"tail_max_charts", 0}})
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond);
// note: a real tile's size after merging (best.json: gutter 2, 500-800 charts on one page): every
// chart in the outline tail's bottom-left search, page-width trials and the block-grid trial; the
// case the tail search's speed work of 2026-12-04 was measured for (docs/speed.md).
BENCHMARK_CAPTURE(BM_Pack, square_tetris_gutter2, std::string("packers.square_tetris"), json{{"gutter", 2}})
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Pack, tetris, std::string("packers.tetris"))->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Pack, shelf, std::string("packers.shelf"))->Arg(10000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
