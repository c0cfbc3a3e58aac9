// Image test helpers: OpenImageIO 2.4 as read_image/write_image used it before PNG and JPEG had
// their own codecs (the reference the new codecs are compared with), and writers of raw PNG/JPEG
// variants through libpng/libjpeg (every colour type, bit depth, sampling, CMYK, progressive).
#pragma once

#include "texdefrag/io/image.h"

#include <OpenImageIO/imageio.h>
#include <png.h>

#include <cstddef>
#include <cstdio>
#include <jpeglib.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag::image_test {

/// read_image as it was (OpenImageIO, unassociated alpha, 8 bits, at most 4 channels).
inline Image oiio_read(const std::string& path) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) throw std::runtime_error(path + ": OpenImageIO: " + OIIO::geterror());
  Image img;
  img.width = in->spec().width;
  img.height = in->spec().height;
  img.channels = std::min(in->spec().nchannels, 4);
  img.pixels.resize(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * static_cast<size_t>(img.channels));
  if (!in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::UINT8, img.pixels.data()))
    throw std::runtime_error(path + ": OpenImageIO: " + in->geterror());
  return img;
}

/// write_image as it was: OpenImageIO picks the writer by extension; JPEG quality and subsampling
/// attributes as set_jpeg_encoding set them; alpha dropped for JPEG.
inline void oiio_write(const std::string& path, const Image& image, bool jpeg, int quality, const char* subsampling) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw std::runtime_error(path + ": no writer");
  int channels = image.channels;
  if (jpeg && (channels == 2 || channels == 4)) channels -= 1;
  OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::UINT8);
  if (channels == 2 || channels == 4) {
    spec.alpha_channel = channels - 1;
    spec.attribute("oiio:UnassociatedAlpha", 1);
  }
  if (jpeg) {
    spec.attribute("Compression", "jpeg:" + std::to_string(quality));
    spec.attribute("CompressionQuality", quality);
    spec.attribute("jpeg:subsampling", subsampling);
  }
  if (!out->open(path, spec)) throw std::runtime_error(path + ": " + out->geterror());
  const auto px = static_cast<OIIO::stride_t>(image.channels);
  if (!out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data(), px, px * image.width) || !out->close())
    throw std::runtime_error(path + ": " + out->geterror());
}

/// A PNG of any colour type and bit depth; `rows` holds the packed rows as PNG stores them
/// (16-bit samples big-endian). palette: RGB triples; trns: tRNS bytes (palette alphas, or the
/// grey/RGB key as 16-bit big-endian values).
struct RawPng {
  int width = 0, height = 0, colour_type = PNG_COLOR_TYPE_GRAY, bit_depth = 8;
  bool interlaced = false;
  std::vector<uint8_t> rows, palette, trns;
};

inline void write_raw_png(const std::string& path, const RawPng& p) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error(path + ": cannot create");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  // Every C++ object is made before setjmp, so a longjmp back here skips no destructor.
  std::vector<png_color> pal;
  for (size_t i = 0; i + 2 < p.palette.size(); i += 3) pal.push_back({p.palette[i], p.palette[i + 1], p.palette[i + 2]});
  png_color_16 key{};
  const size_t stride = p.rows.size() / static_cast<size_t>(p.height);
  std::vector<png_bytep> rows(static_cast<size_t>(p.height));
  for (size_t y = 0; y < rows.size(); ++y) rows[y] = const_cast<png_bytep>(p.rows.data() + y * stride);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
    throw std::runtime_error(path + ": libpng failed");
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, static_cast<png_uint_32>(p.width), static_cast<png_uint_32>(p.height), p.bit_depth,
               p.colour_type, p.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  if (!pal.empty()) png_set_PLTE(png, info, pal.data(), static_cast<int>(pal.size()));
  if (!p.trns.empty()) {
    if (p.colour_type == PNG_COLOR_TYPE_PALETTE) {
      png_set_tRNS(png, info, p.trns.data(), static_cast<int>(p.trns.size()), nullptr);
    } else {
      key.gray = key.red = static_cast<png_uint_16>(p.trns[0] << 8 | p.trns[1]);
      if (p.trns.size() >= 6) {
        key.green = static_cast<png_uint_16>(p.trns[2] << 8 | p.trns[3]);
        key.blue = static_cast<png_uint_16>(p.trns[4] << 8 | p.trns[5]);
      }
      png_set_tRNS(png, info, nullptr, 0, &key);
    }
  }
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

/// A JPEG through libjpeg: `components` samples per pixel in `in_space`, stored as `space`.
struct RawJpeg {
  int width = 0, height = 0, components = 3;
  J_COLOR_SPACE in_space = JCS_RGB, space = JCS_YCbCr;
  int h_samp = 1, v_samp = 1, quality = 90, restart_rows = 0;
  bool progressive = false;
  std::vector<uint8_t> pixels;
};

inline void write_raw_jpeg(const std::string& path, const RawJpeg& j) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error(path + ": cannot create");
  jpeg_compress_struct c{};
  jpeg_error_mgr err{};
  c.err = jpeg_std_error(&err);  // valid input only: the default error_exit exits the test
  jpeg_create_compress(&c);
  jpeg_stdio_dest(&c, f);
  c.image_width = static_cast<JDIMENSION>(j.width);
  c.image_height = static_cast<JDIMENSION>(j.height);
  c.input_components = j.components;
  c.in_color_space = j.in_space;
  jpeg_set_defaults(&c);
  jpeg_set_colorspace(&c, j.space);
  jpeg_set_quality(&c, j.quality, TRUE);
  c.comp_info[0].h_samp_factor = j.h_samp;
  c.comp_info[0].v_samp_factor = j.v_samp;
  c.restart_in_rows = j.restart_rows;
  if (j.progressive) jpeg_simple_progression(&c);
  jpeg_start_compress(&c, TRUE);
  const size_t stride = static_cast<size_t>(j.width) * static_cast<size_t>(j.components);
  while (c.next_scanline < c.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(j.pixels.data() + stride * c.next_scanline);
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  jpeg_destroy_compress(&c);
  std::fclose(f);
}

/// Deterministic noise bytes.
inline std::vector<uint8_t> noise(size_t n, uint32_t seed) {
  std::vector<uint8_t> v(n);
  for (uint8_t& b : v) {
    seed = seed * 1664525u + 1013904223u;
    b = static_cast<uint8_t>(seed >> 24);
  }
  return v;
}

}  // namespace texdefrag::image_test
