// PNG through libpng (see image_codec.h).
//
// Error handling: libpng calls on_error, which must not return; it copies the message and
// longjmps to the setjmp of the guarded function that made the libpng call (start_reading,
// read_rows, encode). Those functions create no C++ object with a destructor, so the jump skips
// nothing that needs cleaning up; the structures libpng allocated are released by the guard
// objects (PngRead, PngWrite) of the calling C++ function, which the jump never leaves.
#include "image_codec.h"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstring>
#include <new>
#include <stdexcept>
#include <vector>

namespace texdefrag::image_codec {
namespace {

/// What the libpng callbacks see. Trivially destructible, so a longjmp may pass over it.
struct PngState {
  std::jmp_buf jump;
  char error[256];
  Source* src;
  std::FILE* out;
};

void set_message(char* dst, size_t n, const char* msg) {
  std::snprintf(dst, n, "%s", msg && *msg ? msg : "unknown error");
}

[[noreturn]] void on_error(png_structp png, png_const_charp msg) {
  auto* s = static_cast<PngState*>(png_get_error_ptr(png));
  set_message(s->error, sizeof s->error, msg);
  std::longjmp(s->jump, 1);
}

// note: warnings (bad ancillary chunk CRCs, unknown chunks, ...) are dropped as OpenImageIO's
// reader dropped them; libpng has already recovered when it calls this.
void on_warning(png_structp, png_const_charp) {}

void on_read(png_structp png, png_bytep data, size_t n) {
  auto* s = static_cast<PngState*>(png_get_io_ptr(png));
  if (s->src->read(data, n) != n) png_error(png, "the file ends early (truncated)");
}

void on_write(png_structp png, png_bytep data, size_t n) {
  auto* s = static_cast<PngState*>(png_get_io_ptr(png));
  if (std::fwrite(data, 1, n, s->out) != n) {
    char msg[200];
    std::snprintf(msg, sizeof msg, "cannot write: %s", std::strerror(errno));
    png_error(png, msg);
  }
}

void on_flush(png_structp) {}

struct PngRead {
  PngState st{};
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngRead() = default;
  PngRead(const PngRead&) = delete;
  PngRead& operator=(const PngRead&) = delete;
  ~PngRead() {
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
  }
};

/// Guarded: creates the reader, reads the header and sets the transforms (image_codec.h).
bool start_reading(PngRead& r) {
  if (setjmp(r.st.jump)) return false;
  r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r.st, on_error, on_warning);
  if (!r.png) {
    set_message(r.st.error, sizeof r.st.error, "out of memory");
    return false;
  }
  r.info = png_create_info_struct(r.png);
  if (!r.info) png_error(r.png, "out of memory");
  png_set_read_fn(r.png, &r.st, on_read);
  png_read_info(r.png, r.info);
  png_set_expand(r.png);      // palette -> RGB, grey 1/2/4 bits -> 8, tRNS -> alpha
  png_set_scale_16(r.png);    // 16 bits -> 8, rounded
  png_set_interlace_handling(r.png);
  png_read_update_info(r.png, r.info);
  return true;
}

/// Guarded: decodes every row (all Adam7 passes) into rows, then reads the chunks after the
/// image data up to IEND, so a file cut anywhere is an error.
bool read_rows(PngRead& r, png_bytepp rows) {
  if (setjmp(r.st.jump)) return false;
  png_read_image(r.png, rows);
  png_read_end(r.png, nullptr);
  return true;
}

struct PngWrite {
  PngState st{};
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngWrite() = default;
  PngWrite(const PngWrite&) = delete;
  PngWrite& operator=(const PngWrite&) = delete;
  ~PngWrite() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
  }
};

/// Guarded: encodes the whole image.
bool encode(PngWrite& w, const Image& image) {
  if (setjmp(w.st.jump)) return false;
  w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &w.st, on_error, on_warning);
  if (!w.png) {
    set_message(w.st.error, sizeof w.st.error, "out of memory");
    return false;
  }
  w.info = png_create_info_struct(w.png);
  if (!w.info) png_error(w.png, "out of memory");
  png_set_write_fn(w.png, &w.st, on_write, on_flush);
  static const int kColourType[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                     PNG_COLOR_TYPE_RGB_ALPHA};
  png_set_IHDR(w.png, w.info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               kColourType[image.channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(w.png, 6);
  png_write_info(w.png, w.info);
  const size_t stride = static_cast<size_t>(image.width) * static_cast<size_t>(image.channels);
  for (int y = 0; y < image.height; ++y) png_write_row(w.png, image.pixels.data() + stride * static_cast<size_t>(y));
  png_write_end(w.png, w.info);
  return true;
}

}  // namespace

Image read_png(Source& src, const std::string& name, bool header_only) {
  PngRead r;
  r.st.src = &src;
  if (!start_reading(r)) throw ImageError(name + ": cannot read image: PNG: " + r.st.error);
  Image img;
  img.width = static_cast<int>(png_get_image_width(r.png, r.info));
  img.height = static_cast<int>(png_get_image_height(r.png, r.info));
  img.channels = png_get_channels(r.png, r.info);
  const size_t stride = static_cast<size_t>(img.width) * static_cast<size_t>(img.channels);
  if (img.width <= 0 || img.height <= 0 || img.channels < 1 || img.channels > 4 ||
      png_get_rowbytes(r.png, r.info) != stride)
    throw ImageError(name + ": cannot read image: PNG: unexpected layout after conversion to 8 bits (" +
                     std::to_string(img.width) + "x" + std::to_string(img.height) + ", " +
                     std::to_string(img.channels) + " channels)");
  if (header_only) return img;
  std::vector<png_bytep> rows;
  try {
    img.pixels.resize(stride * static_cast<size_t>(img.height));
    rows.resize(static_cast<size_t>(img.height));
  } catch (const std::exception&) {  // bad_alloc, length_error
    throw ImageError(name + ": image too large to hold in memory (" + std::to_string(img.width) + "x" +
                     std::to_string(img.height) + ")");
  }
  for (size_t y = 0; y < rows.size(); ++y) rows[y] = img.pixels.data() + stride * y;
  if (!read_rows(r, rows.data())) throw ImageError(name + ": cannot read pixels: PNG: " + r.st.error);
  return img;
}

void write_png(std::FILE* out, const Image& image, const std::string& name) {
  PngWrite w;
  w.st.out = out;
  if (!encode(w, image)) throw ImageError(name + ": write failed: PNG: " + w.st.error);
}

Kind sniff(const uint8_t* head, size_t n) {
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (n >= 8 && std::memcmp(head, kPng, 8) == 0) return Kind::Png;
  if (n >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) return Kind::Jpeg;
  return Kind::Other;
}

}  // namespace texdefrag::image_codec
