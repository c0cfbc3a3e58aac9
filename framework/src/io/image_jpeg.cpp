// JPEG through libjpeg-turbo (see image_codec.h).
//
// Error handling: libjpeg calls on_error, which must not return; it formats the message and
// longjmps to the setjmp of the guarded function that made the libjpeg call (start_reading,
// read_rows, encode). Those functions create no C++ object with a destructor, so the jump skips
// nothing that needs cleaning up; the library's memory is released by the guard objects
// (JpegRead, JpegWrite) of the calling C++ function, which the jump never leaves.
#include "image_codec.h"

// jpeglib.h needs size_t and FILE declared first.
#include <cstddef>
#include <cstdio>

#include <jerror.h>
#include <jpeglib.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <new>
#include <stdexcept>
#include <vector>

namespace texdefrag::image_codec {
namespace {

/// libjpeg's error manager plus what the callbacks record. Trivially destructible.
struct JpegErrors {
  jpeg_error_mgr pub;  // first member: libjpeg sees a jpeg_error_mgr*
  std::jmp_buf jump;
  char error[JMSG_LENGTH_MAX];
  char warning[JMSG_LENGTH_MAX];  ///< the first corrupt-data warning
  int warnings;
};

[[noreturn]] void on_error(j_common_ptr c) {
  auto* e = reinterpret_cast<JpegErrors*>(c->err);
  c->err->format_message(c, e->error);
  std::longjmp(e->jump, 1);
}

/// Level -1: a corrupt-data warning (libjpeg has recovered and goes on); higher levels are trace
/// messages. Nothing is printed.
void on_message(j_common_ptr c, int level) {
  if (level >= 0) return;
  auto* e = reinterpret_cast<JpegErrors*>(c->err);
  if (e->warnings++ == 0) c->err->format_message(c, e->warning);
  c->err->num_warnings++;
}

void on_output(j_common_ptr) {}

void install(JpegErrors& e) {
  jpeg_std_error(&e.pub);
  e.pub.error_exit = on_error;
  e.pub.emit_message = on_message;
  e.pub.output_message = on_output;
}

struct JpegRead {
  JpegErrors err{};
  jpeg_decompress_struct cinfo{};  // zeroed: jpeg_destroy_decompress is a no-op until created
  JpegRead() = default;
  JpegRead(const JpegRead&) = delete;
  JpegRead& operator=(const JpegRead&) = delete;
  ~JpegRead() { jpeg_destroy_decompress(&cinfo); }
};

/// Guarded: creates the decompressor, reads the header and, unless header_only, starts decoding.
bool start_reading(JpegRead& r, Source& src, bool header_only) {
  install(r.err);
  r.cinfo.err = &r.err.pub;
  if (setjmp(r.err.jump)) return false;
  jpeg_create_decompress(&r.cinfo);
  if (src.file)
    jpeg_stdio_src(&r.cinfo, src.file);
  else
    jpeg_mem_src(&r.cinfo, src.data, static_cast<unsigned long>(src.size));
  jpeg_read_header(&r.cinfo, TRUE);
  // CMYK and YCCK are decoded to CMYK, then turned into RGB by cmyk_to_rgb.
  if (r.cinfo.jpeg_color_space == JCS_CMYK || r.cinfo.jpeg_color_space == JCS_YCCK) r.cinfo.out_color_space = JCS_CMYK;
  if (!header_only) jpeg_start_decompress(&r.cinfo);
  return true;
}

/// OpenImageIO 2.4's conversion (jpeginput.cpp): the stored values are taken as inverted
/// (Adobe's convention), each channel times K in [0, 1] floats, rounded half up.
void cmyk_to_rgb(const uint8_t* cmyk, uint8_t* rgb, size_t n) {
  for (size_t i = 0; i < n; ++i, cmyk += 4, rgb += 3) {
    const float k = cmyk[3] * (1.0f / 255.0f);
    for (int c = 0; c < 3; ++c) {
      float v = cmyk[c] * (1.0f / 255.0f) * k * 255.0f + 0.5f;
      v = v < 0.0f ? 0.0f : (v > 255.0f ? 255.0f : v);
      rgb[c] = static_cast<uint8_t>(v);
    }
  }
}

/// Guarded: decodes every scanline into out (rows of `stride` bytes), then reads to the end.
bool read_rows(JpegRead& r, uint8_t* out, size_t stride, uint8_t* cmyk_row) {
  if (setjmp(r.err.jump)) return false;
  while (r.cinfo.output_scanline < r.cinfo.output_height) {
    uint8_t* dst = out + stride * r.cinfo.output_scanline;
    JSAMPROW row = cmyk_row ? cmyk_row : dst;
    if (jpeg_read_scanlines(&r.cinfo, &row, 1) != 1) ERREXIT(&r.cinfo, JERR_INPUT_EMPTY);
    if (cmyk_row) cmyk_to_rgb(cmyk_row, dst, r.cinfo.output_width);
  }
  jpeg_finish_decompress(&r.cinfo);
  return true;
}

struct JpegWrite {
  JpegErrors err{};
  jpeg_compress_struct cinfo{};
  JpegWrite() = default;
  JpegWrite(const JpegWrite&) = delete;
  JpegWrite& operator=(const JpegWrite&) = delete;
  ~JpegWrite() { jpeg_destroy_compress(&cinfo); }
};

/// The APP1 block OpenImageIO 2.4 writes for an image without metadata: "Exif\0\0" and a
/// little-endian TIFF header whose first IFD has no entries.
const uint8_t kEmptyExif[20] = {'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0};

/// libjpeg's zig-zag order: kZigzag[k] is the natural (row-major) index of the k-th coefficient.
const int kZigzag[64] = {0,  1,  8,  16, 9,  2,  3,  10, 17, 24, 32, 25, 18, 11, 4,  5,  12, 19, 26, 33, 40, 48,
                         41, 34, 27, 20, 13, 6,  7,  14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
                         30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};

/// Guarded: encodes the whole image; row is scratch for one row of 1 or 3 channels.
bool encode(JpegWrite& w, std::FILE* out, const Image& image, int quality, JpegSubsampling subsampling,
            JpegCoding coding, uint8_t* row) {
  install(w.err);
  w.cinfo.err = &w.err.pub;
  if (setjmp(w.err.jump)) return false;
  jpeg_create_compress(&w.cinfo);
  jpeg_stdio_dest(&w.cinfo, out);
  const int components = image.channels >= 3 ? 3 : 1;
  w.cinfo.image_width = static_cast<JDIMENSION>(image.width);
  w.cinfo.image_height = static_cast<JDIMENSION>(image.height);
  w.cinfo.input_components = components;
  w.cinfo.in_color_space = components == 3 ? JCS_RGB : JCS_GRAYSCALE;
  jpeg_set_defaults(&w.cinfo);
  if (coding.tables == JpegTables::Flat) {
    unsigned int table[64];
    flat_jpeg_table(quality, table);
    jpeg_add_quant_table(&w.cinfo, 0, table, 100, TRUE);  // scale 100%: the steps as given
    jpeg_add_quant_table(&w.cinfo, 1, table, 100, TRUE);
  } else {
    jpeg_set_quality(&w.cinfo, quality, TRUE);
  }
  if (coding.progressive) jpeg_simple_progression(&w.cinfo);  // implies optimised Huffman tables
  if (components == 3) {
    w.cinfo.comp_info[0].h_samp_factor = subsampling == JpegSubsampling::S444 ? 1 : 2;
    w.cinfo.comp_info[0].v_samp_factor = subsampling == JpegSubsampling::S420 ? 2 : 1;
  }
  jpeg_start_compress(&w.cinfo, TRUE);
  jpeg_write_marker(&w.cinfo, JPEG_APP0 + 1, kEmptyExif, sizeof kEmptyExif);
  const size_t stride = static_cast<size_t>(image.width) * static_cast<size_t>(image.channels);
  while (w.cinfo.next_scanline < w.cinfo.image_height) {
    const uint8_t* src = image.pixels.data() + stride * w.cinfo.next_scanline;
    JSAMPROW r = const_cast<uint8_t*>(src);  // libjpeg does not write through it
    if (image.channels != components) {
      for (int x = 0; x < image.width; ++x)
        for (int c = 0; c < components; ++c)
          row[x * components + c] = src[x * image.channels + c];
      r = row;
    }
    jpeg_write_scanlines(&w.cinfo, &r, 1);
  }
  jpeg_finish_compress(&w.cinfo);
  return true;
}

}  // namespace

Image read_jpeg(Source& src, const std::string& name, bool header_only) {
  JpegRead r;
  if (!start_reading(r, src, header_only)) throw ImageError(name + ": cannot read image: JPEG: " + r.err.error);
  Image img;
  img.width = static_cast<int>(r.cinfo.image_width);
  img.height = static_cast<int>(r.cinfo.image_height);
  img.channels = r.cinfo.num_components == 1 ? 1 : 3;
  if (header_only) return img;
  const bool cmyk = r.cinfo.out_color_space == JCS_CMYK;
  const int decoded = r.cinfo.output_components;
  if (static_cast<int>(r.cinfo.output_width) != img.width || static_cast<int>(r.cinfo.output_height) != img.height ||
      decoded != (cmyk ? 4 : img.channels))
    throw ImageError(name + ": cannot read image: JPEG: unsupported colour layout (" + std::to_string(decoded) +
                     " decoded channels)");
  const size_t stride = static_cast<size_t>(img.width) * static_cast<size_t>(img.channels);
  std::vector<uint8_t> cmyk_row;
  try {
    img.pixels.resize(stride * static_cast<size_t>(img.height));
    if (cmyk) cmyk_row.resize(static_cast<size_t>(img.width) * 4);
  } catch (const std::exception&) {  // bad_alloc, length_error
    throw ImageError(name + ": image too large to hold in memory (" + std::to_string(img.width) + "x" +
                     std::to_string(img.height) + ")");
  }
  if (!read_rows(r, img.pixels.data(), stride, cmyk ? cmyk_row.data() : nullptr))
    throw ImageError(name + ": cannot read pixels: JPEG: " + r.err.error);
  if (r.err.warnings > 0)
    throw ImageError(name + ": cannot read pixels: JPEG: corrupt or truncated data (" + r.err.warning + ")");
  return img;
}

void flat_jpeg_table(int quality, unsigned int table[64]) {
  const double step = std::clamp(16.0 * jpeg_quality_scaling(quality) / 100.0, 1.0, 255.0);
  const unsigned int low = static_cast<unsigned int>(step);
  const int ceilings = static_cast<int>(std::lround((step - low) * 64.0));  // coefficients one step coarser
  for (int k = 0; k < 64; ++k) table[kZigzag[k]] = low + (k >= 64 - ceilings ? 1u : 0u);
}

void write_jpeg(std::FILE* out, const Image& image, int quality, JpegSubsampling subsampling, const std::string& name,
                JpegCoding coding) {
  JpegWrite w;
  std::vector<uint8_t> row(static_cast<size_t>(image.width) * 3);
  if (!encode(w, out, image, quality, subsampling, coding, row.data()))
    throw ImageError(name + ": write failed: JPEG: " + w.err.error);
}

}  // namespace texdefrag::image_codec
