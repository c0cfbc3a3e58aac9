// Reading speed of the OBJ reader on the largest real model (46k triangles, 24 JPEG pages):
// BM_ReadObj parses OBJ + MTL and reads the 24 image headers; BM_ReadObjNoImages parses only.
// Exits 0 with a message when ../shared/data is absent.
#include "texdefrag/io/obj.h"
#include "texdefrag/util/paths.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace {

const std::string& model() {
  static const std::string path =
      std::string(texdefrag::shared_data_dir()) + "/contextcapture/prod5_t016_L19/t016_L19.obj";
  return path;
}

void BM_ReadObj(benchmark::State& state) {
  size_t faces = 0;
  for (auto _ : state) {
    const texdefrag::TexturedMesh m = texdefrag::read_obj(model());
    faces = m.faces.size();
    benchmark::DoNotOptimize(faces);
  }
  state.counters["faces"] = static_cast<double>(faces);
  state.counters["faces/s"] = benchmark::Counter(static_cast<double>(faces), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_ReadObjNoImages(benchmark::State& state) {
  texdefrag::ObjReadOptions o;
  o.read_page_sizes = false;
  size_t faces = 0;
  for (auto _ : state) {
    const texdefrag::TexturedMesh m = texdefrag::read_obj(model(), o);
    faces = m.faces.size();
    benchmark::DoNotOptimize(faces);
  }
  state.counters["faces"] = static_cast<double>(faces);
  state.counters["faces/s"] = benchmark::Counter(static_cast<double>(faces), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

int main(int argc, char** argv) {
  std::error_code ec;
  if (!std::filesystem::exists(model(), ec)) {
    std::printf("bench_obj_read: skipped, %s is absent\n", model().c_str());
    return 0;
  }
  benchmark::RegisterBenchmark("BM_ReadObj/t016_L19", BM_ReadObj)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_ReadObjNoImages/t016_L19", BM_ReadObjNoImages)->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
