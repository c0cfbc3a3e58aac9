// Generation time of a 100k-face building (issue 3 target: under 5 s), with and without rendering
// the atlas pages.
#include "texdefrag/synth/synth.h"

#include <benchmark/benchmark.h>

namespace {

void generate_building(benchmark::State& state, texdefrag::synth::Archetype a, bool render) {
  texdefrag::synth::SynthOptions o;
  o.archetype = a;
  o.target_faces = static_cast<size_t>(state.range(0));
  o.seed = 1;
  o.render_pages = render;
  size_t faces = 0;
  for (auto _ : state) {
    const auto m = texdefrag::synth::generate(o);
    faces = m.mesh.faces.size();
    benchmark::DoNotOptimize(faces);
  }
  state.counters["faces"] = static_cast<double>(faces);
}

void BM_SynthHotel(benchmark::State& s) { generate_building(s, texdefrag::synth::Archetype::Hotel, true); }
void BM_SynthFactory(benchmark::State& s) { generate_building(s, texdefrag::synth::Archetype::Factory, true); }
void BM_SynthHotelGeometryOnly(benchmark::State& s) { generate_building(s, texdefrag::synth::Archetype::Hotel, false); }

}  // namespace

BENCHMARK(BM_SynthHotel)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_SynthFactory)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_SynthHotelGeometryOnly)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_MAIN();
