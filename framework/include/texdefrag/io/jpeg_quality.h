// JPEG quality estimation from the quantisation tables (DQT segments) of a JPEG stream.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

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

}  // namespace texdefrag
