// Texture page images: 8-bit, 1-4 channels, rows top to bottom. PNG and JPEG through libpng and
// libjpeg-turbo; other formats through OpenImageIO, loaded only when such a file is met (docs/io.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

struct ImageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;  ///< row-major, row 0 is the top of the image, channels interleaved

  uint8_t* at(int x, int y) { return &pixels[(static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * static_cast<size_t>(channels)]; }
  const uint8_t* at(int x, int y) const { return &pixels[(static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * static_cast<size_t>(channels)]; }
  bool empty() const { return pixels.empty(); }
};

/// Reads an image. The format comes from the first bytes, not the name: PNG (every colour type and
/// bit depth: palette expanded to RGB, tRNS to alpha, 1-4 bit grey scaled, 16 bits rounded to 8)
/// and JPEG (baseline or progressive; grey gives 1 channel, colour 3, CMYK/YCCK converted to RGB)
/// are decoded by libpng/libjpeg-turbo; anything else (TIFF, BMP, TGA, OpenEXR, ...) by OpenImageIO's
/// module (<root>/lib/texdefrag/texdefrag_image_oiio.so), loaded on first use: deeper formats are
/// converted to 8 bits, channels beyond the 4th are not read, the first subimage / MIP level is read.
/// The pixels are those OpenImageIO 2.4 gave for every format. Alpha is returned as stored (not
/// premultiplied); colour profiles, gamma and EXIF orientation are not applied.
/// Throws ImageError starting with the path: missing file, corrupt or truncated data, a format
/// without a reader; no decoder message is printed.
Image read_image(const std::string& path);

/// Decodes a PNG or JPEG held in memory as read_image does (anything else: ImageError). `name` starts
/// every error message. header_only: width, height and channels only, pixels left empty.
Image decode_image(const uint8_t* data, size_t size, const std::string& name, bool header_only = false);

/// Reads only the header: width and height. Throws ImageError naming the file.
void read_image_size(const std::string& path, int& width, int& height);

enum class ImageFormat { Png, Jpeg };

/// JPEG chroma subsampling (horizontal:vertical sampling of Cb/Cr against Y). S444 keeps every
/// colour sample; S420 (libjpeg's default) halves both directions.
enum class JpegSubsampling { S444, S422, S420 };

/// "4:4:4", "4:2:2", "4:2:0".
const char* jpeg_subsampling_name(JpegSubsampling s);

/// JPEG quantisation tables (docs/io.md "Page format").
/// Standard: libjpeg's (ITU T.81 Annex K) luminance and chrominance tables scaled by the quality
///   (jpeg_set_quality): coarse steps at high frequencies and for colour, tuned for the eye.
/// Flat: one step for every coefficient of every component, the step of the standard tables' base
///   value 16 scaled by the same quality (16 x jpeg_quality_scaling(q) / 100, at least 1), as a real
///   number: the lowest-frequency coefficients (zig-zag order) take its floor and the others its
///   ceiling, so the mean step is the real one and one quality more is a small step in bytes. For
///   the squared error (PSNR) against the page, a flat table is the best allocation at a given size
///   (every DCT coefficient's error counts the same), and on photographic atlases it gives 2-3 dB
///   more than the standard tables at the same bytes (docs/bench.md).
enum class JpegTables { Standard, Flat };

/// How a JPEG is coded beyond quality and subsampling.
struct JpegCoding {
  JpegTables tables = JpegTables::Standard;
  /// Progressive scans (libjpeg's jpeg_simple_progression) with optimised Huffman tables: the same
  /// pixels, fewer bytes (3-5% on atlases). Off: baseline with the standard Huffman tables.
  bool progressive = false;
};

/// "standard", "flat".
const char* jpeg_tables_name(JpegTables t);

/// Writes an image atomically (temporary file, then rename). jpeg_quality in [1, 100].
/// path: must end in .png for Png, .jpg/.jpeg for Jpeg (else ImageError); its folder must exist.
/// image: 1-4 channels, pixels.size() == width*height*channels (else ImageError). JPEG stores 1 or
///        3 channels: the alpha of a 2- or 4-channel image is left out. PNG round-trips exactly.
/// subsampling: chroma subsampling of a 3-channel JPEG (ignored for PNG and grey JPEG); the default
///        is libjpeg's own (4:2:0); the pipeline's pages pass output.jpeg_subsampling (4:4:4).
/// Encoding: PNG with zlib level 6; JPEG with the default `coding` (baseline, libjpeg's standard
/// tables scaled to the quality and standard Huffman tables) is byte for byte what OpenImageIO 2.4
/// wrote (JFIF and an empty EXIF block); `coding` may ask for flat tables and progressive scans.
/// Throws ImageError naming `path`; on failure no file and no temporary is left.
void write_image(const std::string& path, const Image& image, ImageFormat format, int jpeg_quality = 95,
                 JpegSubsampling subsampling = JpegSubsampling::S420, JpegCoding coding = {});

}  // namespace texdefrag
