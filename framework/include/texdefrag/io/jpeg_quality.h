// JPEG header reading: quality estimated from the quantisation tables (DQT segments), chroma
// subsampling from the frame header (SOF).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

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

}  // namespace texdefrag
