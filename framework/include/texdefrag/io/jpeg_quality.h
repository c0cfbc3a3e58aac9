// JPEG header reading: quality estimated from the quantisation tables (DQT segments), chroma
// subsampling from the frame header (SOF).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "texdefrag/io/image.h"

namespace texdefrag {

/// The IJG (libjpeg) quality 1..100 whose scaled standard tables are nearest to the stream's
/// quantisation tables (sum of absolute differences over the luminance table, and the chrominance
/// table when present), i.e. the `-quality` a libjpeg encoder would need to produce tables like
/// these. Encoders that do not scale the IJG tables get the nearest such quality.
/// data/size: a JPEG stream from its SOI marker; may be truncated after the last DQT.
/// Returns empty when the bytes are not a JPEG stream or hold no 8-bit DQT before the first SOS.
std::optional<int> estimate_jpeg_quality(const uint8_t* data, size_t size);

/// estimate_jpeg_quality over a file's first 64 KiB (the DQT segments precede the scan data).
/// Returns empty when the file cannot be read or is not a JPEG.
std::optional<int> estimate_jpeg_quality_of_file(const std::string& path);

/// The chroma subsampling of a JPEG stream's frame header (SOFn): the luminance sampling factors
/// against the first chrominance component's. 1x1 -> S444, 2x1 or 1x2 -> S422, 2x2 or coarser
/// (4:1:1, 4:1:0) -> S420 (the nearest we write that keeps no more colour than the input had).
/// data/size: a JPEG stream from its SOI marker; may be truncated after the SOF.
/// Returns empty when the bytes are not a JPEG stream, hold no SOF before the first SOS, or the
/// image has fewer than 3 components (grey: nothing to subsample).
std::optional<JpegSubsampling> read_jpeg_subsampling(const uint8_t* data, size_t size);

/// read_jpeg_subsampling over a file's first 64 KiB. Empty when unreadable or not a JPEG.
std::optional<JpegSubsampling> read_jpeg_subsampling_of_file(const std::string& path);

/// The quality of the flat tables (image.h JpegTables::Flat) whose step is at most the root mean
/// square step of the standard tables at `standard_quality` (luminance table for Y, chrominance
/// table for Cb and Cr, each component counted once): the lowest flat quality whose quantisation
/// noise (step^2 / 12 per coefficient) is no larger than the standard tables'. JPEG pages with flat
/// tables never go below it, as standard pages never go below the input's estimate. E.g. 90 -> 48
/// (rms step 16.8, mostly the chrominance table's 99 x 0.2), 95 -> 74, 98 -> 90, 100 -> 97 (step 1:
/// flat 97-100 are one table). The step equivalence is that of coefficients larger than the steps;
/// it is a floor for budgets the pages cannot meet, the fit raises the quality from it. Out-of-range
/// input is clamped to [1, 100].
int flat_quality_for_standard(int standard_quality);

/// The bytes write_image writes for `image` as a JPEG at these settings (the same encoder), in
/// memory. Throws ImageError starting with `name` when encoding fails.
std::vector<uint8_t> encode_jpeg(const Image& image, int quality, JpegSubsampling subsampling,
                                 const std::string& name = "page", JpegCoding coding = {});

/// What fit_jpeg_quality chose.
struct JpegQualityFit {
  int quality = 0;             ///< the quality chosen
  size_t bytes = 0;            ///< total encoded bytes of the pages at `quality` (measured, not estimated)
  int probes = 0;              ///< qualities tried on whole pages (each encodes every page once)
  bool within_budget = false;  ///< bytes <= budget
  int sample_probes = 0;       ///< qualities tried on the pages' samples to predict the answer (0: none)
  /// The pages' encoded streams at `quality` (encode_jpeg's bytes, one per page, in order) when
  /// within_budget: the writer can write them instead of encoding the pages again.
  std::vector<std::vector<uint8_t>> streams;
};

/// The highest JPEG quality in [min_quality, max_quality] (1 <= min <= max <= 100) at which the
/// pages' total encoded bytes (encode_jpeg of every page) are at most `budget`.
/// Search from the ends: max_quality and min_quality are encoded first (max fits: taken; min over:
/// min is taken, within_budget false: the caller's floor is never lowered); then each round encodes
/// up to 3 qualities evenly inside the open interval (fitting, over) and keeps the sub-interval
/// between the highest fitting and the lowest over, until they are adjacent.
/// Pages of 2048 rows or more are first searched that way on a sample (jpeg_fit_sample_bands: 1/8
/// of the rows; its bytes but the fixed part, i.e. those of a 16 x 16 flat image, scaled by the
/// rows' share; smaller pages whole) to predict the quality q;
/// then whole pages are encoded at q and q + 1 (the usual answer: q fits, q + 1 does not), with
/// steps doubling away from them until fitting and over are bracketed, then narrowed as above. A
/// 34 MP page took 11 whole encodes before, 2-3 (plus about 1.4 in samples) now.
/// Encodes run in parallel over (page, quality) pairs (util/parallel.h); the qualities tried depend
/// on the measured bytes only, never on the thread count, so the result is deterministic.
/// Guarantees: `bytes` is the measured total at `quality` (a prediction is never the answer);
/// within_budget => bytes <= budget; quality >= min_quality. JPEG bytes grow with quality almost
/// always but not by theorem: where they do not, the search still returns a quality whose measured
/// bytes fit, and the next quality it tried above it did not fit.
/// The rows fit_jpeg_quality samples on a page of `height` rows to predict its bytes, as (first
/// row, row count) bands: one band of 16 rows from every stratum of 128, which band drawn by a fixed
/// hash of the stratum's index (stratified random sampling: content that repeats with the strata,
/// such as shelves of charts or pages in multiples of 128 rows, is not sampled at one phase only).
std::vector<std::pair<int, int>> jpeg_fit_sample_bands(int height);

JpegQualityFit fit_jpeg_quality(const std::vector<const Image*>& pages, int min_quality, int max_quality,
                                JpegSubsampling subsampling, size_t budget, JpegCoding coding = {});

}  // namespace texdefrag
