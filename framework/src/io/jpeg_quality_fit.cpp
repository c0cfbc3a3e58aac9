// JPEG pages in memory and the quality search under a byte budget (see texdefrag/io/jpeg_quality.h,
// docs/io.md "Page format").
#include "texdefrag/io/jpeg_quality.h"

#include "image_codec.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
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

/// Total encoded bytes of every page at each quality of `qualities`, encoded in parallel over
/// (page, quality); combined in index order.
std::vector<size_t> total_bytes(const std::vector<const Image*>& pages, const std::vector<int>& qualities,
                                JpegSubsampling subsampling, JpegCoding coding) {
  const size_t n = pages.size();
  std::vector<size_t> bytes(n * qualities.size(), 0);
  parallel_for(bytes.size(), [&](size_t i) {
    const size_t q = i / n, p = i % n;
    bytes[i] = encode_jpeg(*pages[p], qualities[q], subsampling, "page " + std::to_string(p), coding).size();
  });
  std::vector<size_t> totals(qualities.size(), 0);
  for (size_t i = 0; i < bytes.size(); ++i) totals[i / n] += bytes[i];
  return totals;
}

}  // namespace

JpegQualityFit fit_jpeg_quality(const std::vector<const Image*>& pages, int min_quality, int max_quality,
                                JpegSubsampling subsampling, size_t budget, JpegCoding coding) {
  if (min_quality < 1 || max_quality > 100 || min_quality > max_quality)
    throw ImageError("fit_jpeg_quality: qualities " + std::to_string(min_quality) + ".." + std::to_string(max_quality) +
                     " are not 1 <= min <= max <= 100");
  JpegQualityFit fit;
  std::vector<int> ends = {max_quality};
  if (min_quality < max_quality) ends.push_back(min_quality);
  const std::vector<size_t> end_bytes = total_bytes(pages, ends, subsampling, coding);
  fit.probes = static_cast<int>(ends.size());
  if (end_bytes[0] <= budget) return {max_quality, end_bytes[0], fit.probes, true};
  if (ends.size() == 1 || end_bytes[1] > budget) return {min_quality, end_bytes.back(), fit.probes, false};
  // Invariant: lo fits (lo_bytes <= budget), hi does not.
  int lo = min_quality, hi = max_quality;
  size_t lo_bytes = end_bytes[1];
  while (hi - lo > 1) {
    std::vector<int> mids;
    const int gaps = std::min(4, hi - lo);  // up to 3 qualities strictly inside (lo, hi)
    for (int k = 1; k < gaps; ++k) {
      const int q = lo + (hi - lo) * k / gaps;
      if (q > lo && q < hi && (mids.empty() || q > mids.back())) mids.push_back(q);
    }
    const std::vector<size_t> b = total_bytes(pages, mids, subsampling, coding);
    fit.probes += static_cast<int>(mids.size());
    int new_lo = lo, new_hi = hi;
    size_t new_lo_bytes = lo_bytes;
    for (size_t k = 0; k < mids.size(); ++k) {
      if (b[k] <= budget) {
        new_lo = mids[k];
        new_lo_bytes = b[k];
      } else {
        new_hi = mids[k];
        break;  // the lowest over bounds the interval; a fitting quality above it is not trusted
      }
    }
    lo = new_lo;
    hi = new_hi;
    lo_bytes = new_lo_bytes;
  }
  return {lo, lo_bytes, fit.probes, true};
}

}  // namespace texdefrag
