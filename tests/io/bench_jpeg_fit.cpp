// Cost of fitting a JPEG page's quality to a byte budget (io/jpeg_quality.h), the write step's
// largest part on big models: BM_EncodeJpeg is one whole encode of a 4096 x 4096 page (flat
// tables, progressive: best.json's pages), BM_FitJpegQuality the search over flat qualities 48-97
// for the budget of that page at flat quality 70. Counters: whole-page and sample encodes, the
// quality found. The page is t016_L19's 24 input pages placed side by side in rows and repeated
// (photographic content, as the pages the writer fits). Exits 0 with a message when
// ../shared/data is absent.
#include "texdefrag/io/image.h"
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/util/paths.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using texdefrag::Image;

constexpr int kSide = 4096;

std::string tile_dir() { return std::string(texdefrag::shared_data_dir()) + "/contextcapture/prod5_t016_L19"; }

/// The tile's pages in name order, copied row after row (shelves) into a kSide x kSide RGB page,
/// again from the first when the page is not full.
Image page() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(tile_dir()))
    if (e.path().extension() == ".jpg") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  std::vector<Image> src;
  for (const std::string& f : files) src.push_back(texdefrag::read_image(f));
  Image out;
  out.width = out.height = kSide;
  out.channels = 3;
  out.pixels.assign(static_cast<size_t>(kSide) * kSide * 3, 0);
  int x = 0, y = 0, shelf = 0;
  for (size_t k = 0; y < kSide; k = (k + 1) % src.size()) {
    const Image& s = src[k];
    if (x + s.width > kSide) x = 0, y += shelf, shelf = 0;
    if (y >= kSide) break;
    for (int r = 0; r < s.height && y + r < kSide; ++r)
      for (int c = 0; c < s.width && x + c < kSide; ++c)
        for (int ch = 0; ch < 3; ++ch) out.at(x + c, y + r)[ch] = s.at(c, r)[std::min(ch, s.channels - 1)];
    x += s.width;
    shelf = std::max(shelf, s.height);
  }
  return out;
}

const Image& bench_page() {
  static const Image p = page();
  return p;
}

texdefrag::JpegCoding best_coding() {
  texdefrag::JpegCoding c;
  c.tables = texdefrag::JpegTables::Flat;
  c.progressive = true;
  return c;
}

void BM_EncodeJpeg(benchmark::State& state) {
  size_t bytes = 0;
  for (auto _ : state) {
    bytes = texdefrag::encode_jpeg(bench_page(), 70, texdefrag::JpegSubsampling::S444, "page", best_coding()).size();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}

void BM_FitJpegQuality(benchmark::State& state) {
  const std::vector<const Image*> pages = {&bench_page()};
  const size_t budget =
      texdefrag::encode_jpeg(bench_page(), 70, texdefrag::JpegSubsampling::S444, "page", best_coding()).size();
  texdefrag::JpegQualityFit fit;
  for (auto _ : state) {
    fit = texdefrag::fit_jpeg_quality(pages, 48, 97, texdefrag::JpegSubsampling::S444, budget, best_coding());
    benchmark::DoNotOptimize(fit.bytes);
  }
  state.counters["quality"] = fit.quality;
  state.counters["whole_encodes"] = fit.probes;
  state.counters["sample_encodes"] = fit.sample_probes;
}

}  // namespace

int main(int argc, char** argv) {
  std::error_code ec;
  if (!fs::exists(tile_dir(), ec)) {
    std::printf("bench_jpeg_fit: skipped, %s is absent\n", tile_dir().c_str());
    return 0;
  }
  benchmark::RegisterBenchmark("BM_EncodeJpeg/4096x4096", BM_EncodeJpeg)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_FitJpegQuality/4096x4096", BM_FitJpegQuality)->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
