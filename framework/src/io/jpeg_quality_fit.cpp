// JPEG pages in memory and the quality search under a byte budget (see texdefrag/io/jpeg_quality.h,
// docs/io.md "Page format").
#include "texdefrag/io/jpeg_quality.h"

#include "image_codec.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <functional>
#include <cstdio>
#include <cstdlib>

namespace texdefrag {

std::vector<uint8_t> encode_jpeg(const Image& image, int quality, JpegSubsampling subsampling,
                                 const std::string& name, JpegCoding coding) {
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
      image.pixels.size() != static_cast<size_t>(image.width) * static_cast<size_t>(image.height) *
                                 static_cast<size_t>(image.channels))
    throw ImageError(name + ": cannot encode: not an 8-bit image of 1-4 channels with width*height*channels bytes");
  if (quality < 1 || quality > 100)
    throw ImageError(name + ": cannot encode: JPEG quality " + std::to_string(quality) + " is not in [1, 100]");
  // open_memstream: the very FILE* path write_image takes, so the bytes are the file's.
  char* buf = nullptr;
  size_t size = 0;
  std::FILE* f = open_memstream(&buf, &size);
  if (!f) throw ImageError(name + ": cannot encode: no memory stream");
  try {
    image_codec::write_jpeg(f, image, quality, subsampling, name, coding);
  } catch (...) {
    std::fclose(f);
    std::free(buf);
    throw;
  }
  std::fclose(f);  // sets buf and size
  std::vector<uint8_t> out(reinterpret_cast<uint8_t*>(buf), reinterpret_cast<uint8_t*>(buf) + size);
  std::free(buf);
  return out;
}

namespace {

/// Rows per sampled band (a whole MCU row at every subsampling) and one band kept of every
/// kSampleEvery: a sample holds about 1/8 of a page's rows.
constexpr int kSampleBand = 16;
constexpr int kSampleEvery = 8;
/// Pages with fewer rows than this are measured whole even when others are sampled.
constexpr int kMinSampledRows = 2048;

/// Totals (bytes) of the pages at each quality asked; a search measures through one of these.
using Measure = std::function<std::vector<double>(const std::vector<int>&)>;

/// Encoded streams of every page at each quality of `qualities` ([quality][page]), encoded in
/// parallel over (page, quality); each slot is written by one task, so the result does not depend
/// on the thread count.
std::vector<std::vector<std::vector<uint8_t>>> encode_all(const std::vector<const Image*>& pages,
                                                        const std::vector<int>& qualities, JpegSubsampling subsampling,
                                                        JpegCoding coding) {
  const size_t n = pages.size();
  std::vector<std::vector<std::vector<uint8_t>>> out(qualities.size(), std::vector<std::vector<uint8_t>>(n));
  parallel_for(n * qualities.size(), [&](size_t i) {
    const size_t q = i / n, p = i % n;
    out[q][p] = encode_jpeg(*pages[p], qualities[q], subsampling, "page " + std::to_string(p), coding);
  });
  return out;
}

/// Totals of the pages' bytes at each quality. A sampled page's bytes are scaled to its page's rows
/// (`weights`), all but its fixed part: headers, tables and scan markers, measured as the bytes of a
/// 16 x 16 flat image at the same quality (`fixed`, one per quality; none when empty). Without that,
/// a narrow page's sample would count its header 8 times.
std::vector<double> weighted_totals(const std::vector<std::vector<std::vector<uint8_t>>>& streams,
                                    const std::vector<double>& weights, const std::vector<double>& fixed = {}) {
  std::vector<double> totals(streams.size(), 0.0);
  for (size_t q = 0; q < streams.size(); ++q) {
    const double f = fixed.empty() ? 0.0 : fixed[q];
    for (size_t p = 0; p < weights.size(); ++p)
      totals[q] += f + weights[p] * std::max(0.0, static_cast<double>(streams[q][p].size()) - f);
  }
  return totals;
}

/// The whole pages' measure, keeping the streams of the one quality the search can still answer:
/// the highest fitting quality below every quality measured over the budget (the searches' `lo`).
class WholePages {
 public:
  WholePages(const std::vector<const Image*>& pages, JpegSubsampling subsampling, JpegCoding coding, double budget)
      : pages_(pages), subsampling_(subsampling), coding_(coding), budget_(budget) {}

  std::vector<double> operator()(const std::vector<int>& qualities) {
    auto streams = encode_all(pages_, qualities, subsampling_, coding_);
    const std::vector<double> totals = weighted_totals(streams, std::vector<double>(pages_.size(), 1.0));
    for (size_t k = 0; k < qualities.size(); ++k)
      if (totals[k] > budget_) lowest_over_ = std::min(lowest_over_, qualities[k]);
    if (kept_quality_ >= lowest_over_) kept_quality_ = 0, kept_.clear();
    for (size_t k = 0; k < qualities.size(); ++k)
      if (totals[k] <= budget_ && qualities[k] < lowest_over_ && qualities[k] > kept_quality_)
        kept_quality_ = qualities[k], kept_ = std::move(streams[k]);
    return totals;
  }

  /// The streams at `quality` when they are the ones kept; empty otherwise.
  std::vector<std::vector<uint8_t>> take(int quality) {
    return quality == kept_quality_ ? std::move(kept_) : std::vector<std::vector<uint8_t>>{};
  }

 private:
  const std::vector<const Image*>& pages_;
  JpegSubsampling subsampling_;
  JpegCoding coding_;
  double budget_;
  int lowest_over_ = 101, kept_quality_ = 0;
  std::vector<std::vector<uint8_t>> kept_;
};

}  // namespace

std::vector<std::pair<int, int>> jpeg_fit_sample_bands(int height) {
  std::vector<std::pair<int, int>> bands;
  const int stratum = kSampleBand * kSampleEvery;
  for (int k = 0; k * stratum < height; ++k) {
    uint64_t h = static_cast<uint64_t>(k) + 0x9E3779B97F4A7C15ull;  // splitmix64's finaliser
    h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
    h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
    h ^= h >> 31;
    const int y0 = std::min(k * stratum + kSampleBand * static_cast<int>(h % kSampleEvery), height - 1);
    bands.emplace_back(y0, std::min(kSampleBand, height - y0));
  }
  return bands;
}

namespace {

/// The bands of jpeg_fit_sample_bands(page.height), stacked into one image.
Image sample_bands(const Image& page) {
  Image s;
  s.width = page.width;
  s.channels = page.channels;
  const size_t row = static_cast<size_t>(page.width) * static_cast<size_t>(page.channels);
  for (const auto& [y0, rows] : jpeg_fit_sample_bands(page.height)) {
    s.pixels.insert(s.pixels.end(), page.pixels.begin() + static_cast<std::ptrdiff_t>(row * static_cast<size_t>(y0)),
                    page.pixels.begin() + static_cast<std::ptrdiff_t>(row * static_cast<size_t>(y0 + rows)));
    s.height += rows;
  }
  return s;
}

JpegQualityFit answer(int quality, size_t bytes, int probes, bool within_budget) {
  JpegQualityFit fit;
  fit.quality = quality;
  fit.bytes = bytes;
  fit.probes = probes;
  fit.within_budget = within_budget;
  return fit;
}

/// Narrows (lo fits, hi over) until adjacent: each round measures up to 3 qualities evenly inside
/// and keeps the sub-interval between the highest fitting and the lowest over.
JpegQualityFit narrow(const Measure& measure, int lo, double lo_bytes, int hi, double budget, int probes) {
  while (hi - lo > 1) {
    std::vector<int> mids;
    const int gaps = std::min(4, hi - lo);  // up to 3 qualities strictly inside (lo, hi)
    for (int k = 1; k < gaps; ++k) {
      const int q = lo + (hi - lo) * k / gaps;
      if (q > lo && q < hi && (mids.empty() || q > mids.back())) mids.push_back(q);
    }
    const std::vector<double> b = measure(mids);
    probes += static_cast<int>(mids.size());
    int new_hi = hi;
    for (size_t k = 0; k < mids.size(); ++k) {
      if (b[k] > budget) {
        new_hi = mids[k];
        break;  // the lowest over bounds the interval; a fitting quality above it is not trusted
      }
      lo = mids[k];
      lo_bytes = b[k];
    }
    hi = new_hi;
  }
  return answer(lo, static_cast<size_t>(lo_bytes), probes, true);
}

/// The search over [min, max] from both ends (max fits: taken; min over: min, not within budget).
JpegQualityFit search_from_ends(const Measure& measure, int min_quality, int max_quality, double budget) {
  std::vector<int> ends = {max_quality};
  if (min_quality < max_quality) ends.push_back(min_quality);
  const std::vector<double> b = measure(ends);
  const int probes = static_cast<int>(ends.size());
  if (b[0] <= budget) return answer(max_quality, static_cast<size_t>(b[0]), probes, true);
  if (ends.size() == 1 || b[1] > budget) return answer(min_quality, static_cast<size_t>(b.back()), probes, false);
  return narrow(measure, min_quality, b[1], max_quality, budget, probes);
}

/// The search from a predicted quality: `start` and start + 1 first (the common answer: start
/// fits, start + 1 does not), then steps doubling away from them until the answer is bracketed,
/// then narrow().
JpegQualityFit search_from(const Measure& measure, int start, int min_quality, int max_quality, double budget) {
  start = std::clamp(start, min_quality, max_quality);
  if (start == max_quality) --start;  // min < max here, so start >= min; max is measured too
  std::vector<double> b = measure({start, start + 1});
  int probes = 2;
  if (b[0] <= budget && b[1] > budget) return answer(start, static_cast<size_t>(b[0]), probes, true);
  if (b[0] <= budget) {  // start + 1 fits too: step up
    int lo = start + 1, step = 1;
    double lo_bytes = b[1];
    while (lo < max_quality) {
      const int q = std::min(max_quality, lo + step);
      const double bq = measure({q})[0];
      ++probes;
      if (bq > budget) return narrow(measure, lo, lo_bytes, q, budget, probes);
      lo = q;
      lo_bytes = bq;
      step *= 2;
    }
    return answer(lo, static_cast<size_t>(lo_bytes), probes, true);
  }
  int hi = start, step = 1;  // start is over: step down
  double hi_bytes = b[0];
  while (hi > min_quality) {
    const int q = std::max(min_quality, hi - step);
    const double bq = measure({q})[0];
    ++probes;
    if (bq <= budget) return narrow(measure, q, bq, hi, budget, probes);
    hi = q;
    hi_bytes = bq;
    step *= 2;
  }
  return answer(min_quality, static_cast<size_t>(hi_bytes), probes, false);  // even the floor is over
}

}  // namespace

JpegQualityFit fit_jpeg_quality(const std::vector<const Image*>& pages, int min_quality, int max_quality,
                                JpegSubsampling subsampling, size_t budget, JpegCoding coding) {
  if (min_quality < 1 || max_quality > 100 || min_quality > max_quality)
    throw ImageError("fit_jpeg_quality: qualities " + std::to_string(min_quality) + ".." + std::to_string(max_quality) +
                     " are not 1 <= min <= max <= 100");
  const double cap = static_cast<double>(budget);
  WholePages whole(pages, subsampling, coding, cap);
  const Measure full = std::ref(whole);
  bool tall = false;
  for (const Image* p : pages) tall = tall || p->height >= kMinSampledRows;
  JpegQualityFit fit;
  if (!tall || min_quality == max_quality) {
    fit = search_from_ends(full, min_quality, max_quality, cap);
  } else {
    // Predict the quality on samples of the tall pages (each sample's bytes scaled by its rows'
    // share), then search from the prediction with whole pages: the answer is measured, not predicted.
    std::vector<Image> samples;
    samples.reserve(pages.size());
    std::vector<const Image*> sampled;
    std::vector<double> weights;
    for (const Image* p : pages) {
      if (p->height < kMinSampledRows) {
        sampled.push_back(p);
        weights.push_back(1.0);
        continue;
      }
      samples.push_back(sample_bands(*p));
      sampled.push_back(&samples.back());
      weights.push_back(static_cast<double>(p->height) / static_cast<double>(samples.back().height));
    }
    Image flat;
    flat.width = flat.height = 16;
    flat.channels = pages.front()->channels;
    flat.pixels.assign(16 * 16 * static_cast<size_t>(flat.channels), 128);
    const Measure predicted = [&](const std::vector<int>& q) {
      std::vector<double> fixed;
      for (const auto& streams : encode_all({&flat}, q, subsampling, coding))
        fixed.push_back(static_cast<double>(streams.front().size()));
      return weighted_totals(encode_all(sampled, q, subsampling, coding), weights, fixed);
    };
    const JpegQualityFit guess = search_from_ends(predicted, min_quality, max_quality, cap);
    fit = search_from(full, guess.quality, min_quality, max_quality, cap);
    fit.sample_probes = guess.probes;
  }
  if (fit.within_budget) fit.streams = whole.take(fit.quality);
  return fit;
}

}  // namespace texdefrag
