// JPEG quality estimation from DQT tables (see texdefrag/io/jpeg_quality.h). The standard tables and
// their scaling are those of the IJG libjpeg (jcparam.c, ITU-T T.81 Annex K).
#include "texdefrag/io/jpeg_quality.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <vector>

namespace texdefrag {
namespace {

// Annex K tables in natural (row-major) order.
constexpr std::array<int, 64> kStdLuminance = {
    16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,  14, 13, 16, 24, 40,  57,
    69, 56, 14, 17, 22,  29,  51,  87,  80, 62, 18, 22, 37,  56,  68,  109, 103, 77, 24, 35, 55, 64,
    81, 104, 113, 92, 49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};
constexpr std::array<int, 64> kStdChrominance = {
    17, 18, 24, 47, 99, 99, 99, 99, 18, 21, 26, 66, 99, 99, 99, 99, 24, 26, 56, 99, 99, 99,
    99, 99, 47, 66, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99,
    99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99};
// Zigzag position k -> natural index (the order DQT stores its 64 values in).
constexpr std::array<int, 64> kNaturalOrder = {
    0,  1,  8,  16, 9,  2,  3,  10, 17, 24, 32, 25, 18, 11, 4,  5,  12, 19, 26, 33, 40, 48,
    41, 34, 27, 20, 13, 6,  7,  14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
    30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};

/// libjpeg's jpeg_quality_scaling + jpeg_add_quant_table with force_baseline.
int scaled(int base, int quality) {
  const int scale = quality < 50 ? 5000 / quality : 200 - quality * 2;
  const long v = (static_cast<long>(base) * scale + 50) / 100;
  return static_cast<int>(std::clamp(v, 1L, 255L));
}

/// Walks the marker segments of a JPEG header, from SOI up to SOS or EOI: f(marker, pos, len) for
/// each segment (pos: its 0xFF byte, len: its length field, >= 2); fill bytes are skipped. Returns
/// false when the data is not a JPEG header (no SOI, a byte that is no marker, a length under 2),
/// true when it reached SOS, EOI or the end of the data, or when f returned false.
template <class F>
bool walk_segments(const uint8_t* data, size_t size, F&& f) {
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8) return false;
  size_t pos = 2;
  while (pos + 4 <= size) {
    if (data[pos] != 0xFF) return false;
    const uint8_t marker = data[pos + 1];
    if (marker == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    if (marker == 0xDA || marker == 0xD9) return true;  // SOS / EOI: no header segment after this
    const size_t len = static_cast<size_t>(data[pos + 2]) << 8 | data[pos + 3];
    if (len < 2) return false;
    if (!f(marker, pos, len)) return true;
    pos += 2 + len;
  }
  return true;
}

}  // namespace

std::optional<int> estimate_jpeg_quality(const uint8_t* data, size_t size) {
  std::array<std::vector<int>, 4> tables;  // natural order, by table id
  bool bad_table = false;
  const bool header = walk_segments(data, size, [&](uint8_t marker, size_t pos, size_t len) {
    if (marker != 0xDB) return true;
    size_t q = pos + 4;
    const size_t end = std::min(size, pos + 2 + len);
    while (q < end) {
      const int precision = data[q] >> 4, id = data[q] & 0x0F;
      const size_t n = precision ? 128 : 64;
      if (id > 3 || q + 1 + n > end) {
        bad_table = true;
        return false;
      }
      std::vector<int> t(64);
      for (size_t k = 0; k < 64; ++k)
        t[static_cast<size_t>(kNaturalOrder[k])] =
            precision ? (data[q + 1 + 2 * k] << 8 | data[q + 2 + 2 * k]) : data[q + 1 + k];
      tables[static_cast<size_t>(id)] = std::move(t);
      q += 1 + n;
    }
    return true;
  });
  if (!header || bad_table) return std::nullopt;
  if (tables[0].empty()) return std::nullopt;
  int best = 0;
  long best_err = std::numeric_limits<long>::max();
  for (int quality = 1; quality <= 100; ++quality) {
    long err = 0;
    for (size_t i = 0; i < 64; ++i) err += std::labs(tables[0][i] - scaled(kStdLuminance[i], quality));
    if (!tables[1].empty())
      for (size_t i = 0; i < 64; ++i) err += std::labs(tables[1][i] - scaled(kStdChrominance[i], quality));
    if (err < best_err) {  // ties keep the lower quality (fewer bytes)
      best_err = err;
      best = quality;
    }
  }
  return best;
}

namespace {

/// The first 64 KiB of a file (JPEG headers precede the scan data); empty when unreadable.
std::vector<uint8_t> file_head(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::vector<uint8_t> buf(64 * 1024);
  in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
  buf.resize(static_cast<size_t>(in.gcount()));
  return buf;
}

}  // namespace

std::optional<int> estimate_jpeg_quality_of_file(const std::string& path) {
  const std::vector<uint8_t> head = file_head(path);
  return estimate_jpeg_quality(head.data(), head.size());
}

std::optional<JpegSubsampling> read_jpeg_subsampling(const uint8_t* data, size_t size) {
  std::optional<JpegSubsampling> found;
  walk_segments(data, size, [&](uint8_t marker, size_t pos, size_t len) {
    // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC).
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (!sof) return true;
    // length(2) precision(1) height(2) width(2) components(1), then 3 bytes per component:
    // id, H<<4|V, table. The first SOF decides (a malformed one: no answer).
    if (len < 8 || pos + 2 + len > size) return false;
    const size_t components = data[pos + 9];
    if (components < 3 || len < 8 + 3 * components) return false;
    const int yh = data[pos + 11] >> 4, yv = data[pos + 11] & 0x0F;
    const int ch = data[pos + 14] >> 4, cv = data[pos + 14] & 0x0F;
    if (ch == 0 || cv == 0) return false;
    const int rh = yh / ch, rv = yv / cv;  // how many luminance samples per chrominance sample
    found = rh <= 1 && rv <= 1 ? JpegSubsampling::S444 : rh * rv == 2 ? JpegSubsampling::S422 : JpegSubsampling::S420;
    return false;
  });
  return found;
}

std::optional<JpegSubsampling> read_jpeg_subsampling_of_file(const std::string& path) {
  const std::vector<uint8_t> head = file_head(path);
  return read_jpeg_subsampling(head.data(), head.size());
}

int flat_quality_for_standard(int standard_quality) {
  if (standard_quality < 1 || standard_quality > 100) return std::clamp(standard_quality, 1, 100);
  // Squared steps of the standard tables: luminance once (Y), chrominance twice (Cb, Cr).
  double sum = 0;
  for (int k = 0; k < 64; ++k) {
    const double y = scaled(kStdLuminance[static_cast<size_t>(k)], standard_quality);
    const double c = scaled(kStdChrominance[static_cast<size_t>(k)], standard_quality);
    sum += y * y + 2 * c * c;
  }
  const double rms = std::sqrt(sum / (3 * 64));
  for (int q = 1; q <= 100; ++q) {
    const int scale = q < 50 ? 5000 / q : 200 - q * 2;
    if (std::clamp(16.0 * scale / 100.0, 1.0, 255.0) <= rms) return q;
  }
  return 100;
}

}  // namespace texdefrag
