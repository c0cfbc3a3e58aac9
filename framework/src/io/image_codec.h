// PNG and JPEG codecs behind texdefrag/io/image.h, on libpng and libjpeg-turbo directly (internal
// header of framework/src/io/image*.cpp; docs/io.md "Images").
//
// Both libraries report errors through a callback that must not return; these codecs longjmp
// from it back into a small function that made no C++ object needing destruction since its
// setjmp (image_png.cpp, image_jpeg.cpp say how), then throw ImageError in ordinary C++ code. No
// library message reaches stderr: the first error and warning text go into the ImageError.
#pragma once

#include "texdefrag/io/image.h"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace texdefrag::image_codec {

/// Where encoded bytes come from: an open file (read from its current position) or memory.
struct Source {
  std::FILE* file = nullptr;     ///< when set, bytes are read from here
  const uint8_t* data = nullptr; ///< otherwise this buffer of `size` bytes
  size_t size = 0;
  size_t pos = 0;                ///< read position in `data`

  /// Copies up to n bytes into out; returns how many (fewer only at the end of the input).
  size_t read(uint8_t* out, size_t n) {
    if (file) return std::fread(out, 1, n, file);
    const size_t k = pos < size ? (n < size - pos ? n : size - pos) : 0;
    for (size_t i = 0; i < k; ++i) out[i] = data[pos + i];
    pos += k;
    return k;
  }
};

/// The file kinds decoded here, from the first bytes.
enum class Kind { Png, Jpeg, Other };
Kind sniff(const uint8_t* head, size_t n);

/// Decodes a PNG. header_only: width, height and channels set, pixels left empty.
/// Pixels as OpenImageIO 2.4 gave them (so every page reads as before): palette expanded to RGB,
/// tRNS to an alpha channel, grey of 1, 2, 4 bits scaled to 8, 16 bits scaled to 8 by rounding
/// (v * 255 / 65535, libpng's png_set_scale_16); alpha as stored; gAMA, sRGB, iCCP, sBIT, bKGD
/// are not applied. Throws ImageError starting with `name`.
Image read_png(Source& src, const std::string& name, bool header_only);

/// Decodes a baseline, extended or progressive JPEG (libjpeg's defaults: islow IDCT, fancy
/// upsampling), 1 channel for grey, 3 for YCbCr/RGB; CMYK and YCCK become RGB as OpenImageIO 2.4
/// made them (R = C * K / 255 on the stored, Adobe-inverted values, rounded). EXIF orientation is
/// not applied (nor was it). A truncated or corrupt file is an ImageError starting with `name`.
Image read_jpeg(Source& src, const std::string& name, bool header_only);

/// Encodes a PNG (zlib level 6, libpng's default filters) of 1-4 channels into `out`.
void write_png(std::FILE* out, const Image& image, const std::string& name);

/// Encodes a JPEG. With the default `coding` it is the baseline JPEG OpenImageIO 2.4 wrote (byte for
/// byte): libjpeg defaults, jpeg_set_quality(quality, force_baseline), the luma sampling factors of
/// `subsampling` for colour, JFIF APP0 then an empty EXIF APP1. coding.tables Flat: flat tables
/// (image.h JpegTables) instead of jpeg_set_quality's; coding.progressive: progressive scans with
/// optimised Huffman tables. 1-channel images are grey; of 2 or 4 channels the last (alpha) is left out.
void write_jpeg(std::FILE* out, const Image& image, int quality, JpegSubsampling subsampling,
                const std::string& name, JpegCoding coding = {});

/// The flat quantisation table of `quality` (image.h JpegTables::Flat), in natural (row-major)
/// order: steps of 16 x jpeg_quality_scaling(quality) / 100 (at least 1, at most 255) spread as floor
/// and ceiling over the zig-zag order so that their mean is that real number.
void flat_jpeg_table(int quality, unsigned int table[64]);

}  // namespace texdefrag::image_codec
