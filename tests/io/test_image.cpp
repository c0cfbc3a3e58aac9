// Image IO: PNG round trip exact, JPEG close, header-only size, 16-bit/TIFF input converted to
// 8 bits, atomic writes, and errors that name the file.
#include "image_test_util.h"
#include "io_test_util.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/util/paths.h"
#include "texdefrag/testing/fixtures.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <cstdlib>
#include <functional>
#include <filesystem>

namespace fs = std::filesystem;
using namespace texdefrag;
namespace tt = texdefrag::testing;
using texdefrag::io_test::count_temporaries;

namespace {

/// A smooth image with a distinct value in each channel (JPEG-friendly).
Image smooth_image(int w, int h, int channels) {
  Image img;
  img.width = w;
  img.height = h;
  img.channels = channels;
  img.pixels.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * static_cast<size_t>(channels));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c)
        img.at(x, y)[c] = static_cast<uint8_t>(40 + x * 120 / (w - 1) + y * 60 / (h - 1) + c * 10);
  return img;
}

/// Noisy image: every byte differs from its neighbours (catches any lossy step in PNG).
Image noisy_image(int w, int h, int channels) {
  Image img;
  img.width = w;
  img.height = h;
  img.channels = channels;
  img.pixels.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * static_cast<size_t>(channels));
  uint32_t s = 12345;
  for (uint8_t& p : img.pixels) {
    s = s * 1664525u + 1013904223u;
    p = static_cast<uint8_t>(s >> 24);
  }
  return img;
}

std::string image_error(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const ImageError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected ImageError";
  return "";
}

}  // namespace

TEST(Image, PngRoundTripIsExactForOneToFourChannels) {
  const std::string dir = tt::temp_dir();
  for (int ch = 1; ch <= 4; ++ch) {
    const Image img = noisy_image(37, 23, ch);
    const std::string p = dir + "/n" + std::to_string(ch) + ".png";
    write_image(p, img, ImageFormat::Png);
    const Image back = read_image(p);
    EXPECT_EQ(back.width, 37);
    EXPECT_EQ(back.height, 23);
    EXPECT_EQ(back.channels, ch);
    EXPECT_EQ(back.pixels, img.pixels) << ch << " channels";
    int w = 0, h = 0;
    read_image_size(p, w, h);
    EXPECT_EQ(w, 37);
    EXPECT_EQ(h, 23);
  }
  EXPECT_EQ(count_temporaries(dir), 0);
}

TEST(Image, RowZeroIsTheTopOfTheFile) {
  // Written through OpenImageIO directly: a 1x2 grey image whose first scanline is 10, second 200.
  const std::string dir = tt::temp_dir();
  const std::string p = dir + "/rows.png";
  auto out = OIIO::ImageOutput::create(p);
  ASSERT_TRUE(out);
  const uint8_t px[2] = {10, 200};
  ASSERT_TRUE(out->open(p, OIIO::ImageSpec(1, 2, 1, OIIO::TypeDesc::UINT8)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px));
  ASSERT_TRUE(out->close());
  const Image img = read_image(p);
  EXPECT_EQ(img.at(0, 0)[0], 10);
  EXPECT_EQ(img.at(0, 1)[0], 200);
}

TEST(Image, JpegRoundTripIsCloseAndQualityMatters) {
  const std::string dir = tt::temp_dir();
  const Image img = smooth_image(64, 48, 3);
  write_image(dir + "/hi.jpg", img, ImageFormat::Jpeg, 95);
  write_image(dir + "/lo.jpeg", img, ImageFormat::Jpeg, 5);
  const Image hi = read_image(dir + "/hi.jpg");
  ASSERT_EQ(hi.width, 64);
  ASSERT_EQ(hi.height, 48);
  ASSERT_EQ(hi.channels, 3);
  double err = 0;
  int worst = 0;
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    const int d = std::abs(int(hi.pixels[i]) - int(img.pixels[i]));
    err += d;
    worst = std::max(worst, d);
  }
  err /= static_cast<double>(img.pixels.size());
  EXPECT_LT(err, 2.0);
  EXPECT_LT(worst, 24);
  EXPECT_LT(fs::file_size(dir + "/lo.jpeg"), fs::file_size(dir + "/hi.jpg"));
  EXPECT_EQ(count_temporaries(dir), 0);
}

TEST(Image, JpegDropsAlpha) {
  const std::string dir = tt::temp_dir();
  write_image(dir + "/rgba.jpg", smooth_image(16, 16, 4), ImageFormat::Jpeg);
  write_image(dir + "/ga.jpg", smooth_image(16, 16, 2), ImageFormat::Jpeg);
  EXPECT_EQ(read_image(dir + "/rgba.jpg").channels, 3);
  EXPECT_EQ(read_image(dir + "/ga.jpg").channels, 1);
}

TEST(Image, SixteenBitAndTiffAreConvertedToEightBit) {
  const std::string dir = tt::temp_dir();
  const uint16_t px[4] = {0, 65535, 32896, 257};  // 0, 255, 128, 1 in 8 bits
  for (const char* name : {"/deep.png", "/deep.tif"}) {
    const std::string p = dir + name;
    auto out = OIIO::ImageOutput::create(p);
    ASSERT_TRUE(out) << p;
    ASSERT_TRUE(out->open(p, OIIO::ImageSpec(2, 2, 1, OIIO::TypeDesc::UINT16)));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT16, px));
    ASSERT_TRUE(out->close());
    const Image img = read_image(p);
    ASSERT_EQ(img.channels, 1);
    EXPECT_EQ(img.pixels, (std::vector<uint8_t>{0, 255, 128, 1})) << p;
  }
}

TEST(Image, FiveChannelsAreCutToFour) {
  const std::string dir = tt::temp_dir();
  const std::string p = dir + "/five.tif";
  auto out = OIIO::ImageOutput::create(p);
  ASSERT_TRUE(out);
  const uint8_t px[5] = {1, 2, 3, 4, 5};
  ASSERT_TRUE(out->open(p, OIIO::ImageSpec(1, 1, 5, OIIO::TypeDesc::UINT8)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px));
  ASSERT_TRUE(out->close());
  const Image img = read_image(p);
  EXPECT_EQ(img.channels, 4);
  EXPECT_EQ(img.pixels, (std::vector<uint8_t>{1, 2, 3, 4}));
}

TEST(Image, ReadErrorsNameTheFile) {
  const std::string dir = tt::temp_dir();
  const std::string absent = dir + "/absent.png";
  EXPECT_EQ(image_error([&] { read_image(absent); }), absent + ": no such file");
  int w, h;
  EXPECT_EQ(image_error([&] { read_image_size(absent, w, h); }), absent + ": no such file");
  const std::string garbage = io_test::write_text(dir, "garbage.png", "not an image at all");
  const std::string msg = image_error([&] { read_image(garbage); });
  EXPECT_EQ(msg.rfind(garbage + ": cannot read image", 0), 0u) << msg;
  EXPECT_EQ(image_error([&] { read_image(dir); }), dir + ": not a regular file");
}

TEST(Image, WriteErrorsNameTheFileAndLeaveNothingBehind) {
  const std::string dir = tt::temp_dir();
  const Image img = smooth_image(8, 8, 3);
  const std::string p = dir + "/x.png";
  EXPECT_EQ(image_error([&] { write_image(dir + "/x.jpg", img, ImageFormat::Png); }),
            dir + "/x.jpg: file extension does not match the format (expected .png)");
  EXPECT_EQ(image_error([&] { write_image(p, img, ImageFormat::Jpeg); }),
            p + ": file extension does not match the format (expected .jpg or .jpeg)");
  EXPECT_EQ(image_error([&] { write_image(dir + "/q.jpg", img, ImageFormat::Jpeg, 0); }),
            dir + "/q.jpg: JPEG quality 0 outside [1, 100]");
  EXPECT_EQ(image_error([&] { write_image(dir + "/q.jpg", img, ImageFormat::Jpeg, 101); }),
            dir + "/q.jpg: JPEG quality 101 outside [1, 100]");
  Image wrong = img;
  wrong.pixels.pop_back();
  EXPECT_EQ(image_error([&] { write_image(p, wrong, ImageFormat::Png); }),
            p + ": pixel buffer holds 191 bytes, expected 192");
  Image five = img;
  five.channels = 5;
  EXPECT_EQ(image_error([&] { write_image(p, five, ImageFormat::Png); }),
            p + ": cannot write an image with 5 channels (expected 1-4)");
  EXPECT_EQ(image_error([&] { write_image(p, Image{}, ImageFormat::Png); }),
            p + ": cannot write an empty image (0x0)");
  const std::string nowhere = dir + "/no/such/dir/x.png";
  const std::string msg = image_error([&] { write_image(nowhere, img, ImageFormat::Png); });
  EXPECT_EQ(msg.rfind(nowhere + ": ", 0), 0u) << msg;
  EXPECT_FALSE(fs::exists(p));
  EXPECT_EQ(count_temporaries(dir), 0);
}

TEST(Image, WriteReplacesAnExistingFileAtomically) {
  const std::string dir = tt::temp_dir();
  const std::string p = dir + "/page.png";
  write_image(p, smooth_image(8, 8, 3), ImageFormat::Png);
  write_image(p, noisy_image(5, 3, 1), ImageFormat::Png);
  const Image back = read_image(p);
  EXPECT_EQ(back.width, 5);
  EXPECT_EQ(back.channels, 1);
  EXPECT_EQ(back.pixels, noisy_image(5, 3, 1).pixels);
  EXPECT_EQ(count_temporaries(dir), 0);
}

TEST(Image, RealJpegPageSizeMatchesPixels) {
  TEXDEFRAG_REQUIRE_DATA(page, "contextcapture/rural_t007_078_L15");
  std::string jpg;
  for (const auto& e : fs::directory_iterator(page))
    if (e.path().extension() == ".jpg") jpg = e.path().string();
  ASSERT_FALSE(jpg.empty());
  int w = 0, h = 0;
  read_image_size(jpg, w, h);
  const Image img = read_image(jpg);
  EXPECT_EQ(img.width, w);
  EXPECT_EQ(img.height, h);
  EXPECT_EQ(img.channels, 3);
  EXPECT_EQ(img.pixels.size(), static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
}

// ---- PNG and JPEG codecs (libpng, libjpeg-turbo) against OpenImageIO 2.4, the reader before ----

namespace {

namespace it = texdefrag::image_test;

void expect_same_image(const Image& got, const Image& want, const std::string& what) {
  EXPECT_EQ(got.width, want.width) << what;
  EXPECT_EQ(got.height, want.height) << what;
  EXPECT_EQ(got.channels, want.channels) << what;
  EXPECT_TRUE(got.pixels == want.pixels) << what << ": pixels differ";
}

/// Runs fn with stderr sent to a temporary file; returns what was printed.
std::string stderr_of(const std::function<void()>& fn) {
  std::fflush(stderr);
  std::FILE* tmp = std::tmpfile();
  const int saved = ::dup(STDERR_FILENO);
  ::dup2(::fileno(tmp), STDERR_FILENO);
  try {
    fn();
  } catch (...) {
  }
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::string s;
  std::rewind(tmp);
  char buf[256];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, tmp)) > 0) s.append(buf, n);
  std::fclose(tmp);
  return s;
}

std::vector<uint8_t> file_bytes(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write_bytes(const std::string& p, const std::vector<uint8_t>& b, size_t n) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(n));
}

}  // namespace

TEST(ImageCodec, PngOfEveryColourTypeAndDepthReadsAsOpenImageIO) {
  const std::string dir = tt::temp_dir();
  struct Kind {
    int type, samples;
    std::vector<int> depths;
  };
  const std::vector<Kind> kinds = {{PNG_COLOR_TYPE_GRAY, 1, {1, 2, 4, 8, 16}},
                                   {PNG_COLOR_TYPE_GRAY_ALPHA, 2, {8, 16}},
                                   {PNG_COLOR_TYPE_RGB, 3, {8, 16}},
                                   {PNG_COLOR_TYPE_RGB_ALPHA, 4, {8, 16}},
                                   {PNG_COLOR_TYPE_PALETTE, 1, {1, 2, 4, 8}}};
  int n = 0;
  for (const Kind& k : kinds)
    for (int depth : k.depths)
      for (int interlaced = 0; interlaced < 2; ++interlaced)
        for (int trns = 0; trns < 2; ++trns) {
          if (trns && (k.type & PNG_COLOR_MASK_ALPHA)) continue;
          it::RawPng p;
          p.width = 13;
          p.height = 7;
          p.colour_type = k.type;
          p.bit_depth = depth;
          p.interlaced = interlaced;
          const size_t stride = (static_cast<size_t>(p.width) * k.samples * depth + 7) / 8;
          p.rows = it::noise(stride * p.height, 77u + n);
          if (k.type == PNG_COLOR_TYPE_PALETTE) {
            p.palette = it::noise(3u << depth, 5u + n);
            if (trns) p.trns = it::noise(std::max(1, (1 << depth) / 2), 9u + n);
          } else if (trns) {
            // the key: the first pixel's value, so at least one texel turns transparent
            const int bytes = depth == 16 ? 2 : 1;
            for (int c = 0; c < k.samples; ++c)
              if (depth == 16)
                p.trns.insert(p.trns.end(), {p.rows[c * 2], p.rows[c * 2 + 1]});
              else
                p.trns.insert(p.trns.end(), {0, static_cast<uint8_t>(depth == 8 ? p.rows[c * bytes] : p.rows[0] >> (8 - depth))});
          }
          const std::string path = dir + "/t" + std::to_string(k.type) + "_" + std::to_string(depth) + "_" +
                                   std::to_string(interlaced) + std::to_string(trns) + ".png";
          it::write_raw_png(path, p);
          const Image want = it::oiio_read(path);
          expect_same_image(read_image(path), want, path);
          int w = 0, h = 0;
          read_image_size(path, w, h);
          EXPECT_EQ(w, 13);
          EXPECT_EQ(h, 7);
          const std::vector<uint8_t> bytes = file_bytes(path);
          expect_same_image(decode_image(bytes.data(), bytes.size(), path), want, path + " (memory)");
          ++n;
        }
  EXPECT_EQ(n, 52);
}

TEST(ImageCodec, SixteenBitPngRoundsAsOpenImageIOForEveryValue) {
  const std::string dir = tt::temp_dir();
  it::RawPng p;
  p.width = p.height = 256;
  p.bit_depth = 16;
  for (int v = 0; v < 65536; ++v) p.rows.insert(p.rows.end(), {static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v & 255)});
  const std::string path = dir + "/ramp16.png";
  it::write_raw_png(path, p);
  expect_same_image(read_image(path), it::oiio_read(path), path);
}

namespace {

/// A grey 16-bit PNG of w x h texels with value v everywhere.
void write_png16(const std::string& path, int w, int h, uint16_t v) {
  it::RawPng p;
  p.width = w;
  p.height = h;
  p.bit_depth = 16;
  for (int i = 0; i < w * h; ++i) p.rows.insert(p.rows.end(), {static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v & 255)});
  it::write_raw_png(path, p);
}

void write_oiio(const std::string& path, OIIO::TypeDesc type) {
  const float px[4] = {0.f, 1.f, 0.5f, 0.25f};
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << path;
  ASSERT_TRUE(out->open(path, OIIO::ImageSpec(2, 2, 1, type)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px));
  ASSERT_TRUE(out->close());
}

}  // namespace

TEST(ImageBits, ReadFromTheHeaderOfEveryFormat) {
  const std::string dir = tt::temp_dir();
  write_png16(dir + "/a16.png", 3, 2, 1000);
  write_image(dir + "/a8.png", smooth_image(4, 4, 3), ImageFormat::Png);
  write_image(dir + "/a8.jpg", smooth_image(16, 16, 3), ImageFormat::Jpeg);
  write_oiio(dir + "/a16.tif", OIIO::TypeDesc::UINT16);
  write_oiio(dir + "/a8.tif", OIIO::TypeDesc::UINT8);
  write_oiio(dir + "/h.exr", OIIO::TypeDesc::HALF);
  const std::vector<std::pair<std::string, int>> want = {{"a16.png", 16}, {"a8.png", 8}, {"a8.jpg", 8},
                                                         {"a16.tif", 16}, {"a8.tif", 8}, {"h.exr", 16}};
  for (const auto& [name, bits] : want) {
    const std::string path = dir + "/" + name;
    EXPECT_EQ(page_encoding_of_file(path).bits, bits) << name;
    const std::vector<uint8_t> bytes = file_bytes(path);
    EXPECT_EQ(image_bits_of_stream(bytes.data(), bytes.size()), bits) << name << " (memory)";
  }
  // A big-endian TIFF header by hand: IFD at 8 with one entry, BitsPerSample SHORT x 3 at offset 26.
  const std::vector<uint8_t> mm = {'M', 'M', 0, 42, 0, 0, 0, 8,  0, 1,  1, 2, 0, 3, 0, 0, 0, 3, 0, 0, 0, 26,
                                   0,   0,   0, 0,  0, 8, 0, 16, 0, 12};
  EXPECT_EQ(image_bits_of_stream(mm.data(), mm.size()), 16);
  // Cut headers and other formats: unknown (0), never a read past the end.
  for (size_t n : {size_t(0), size_t(3), size_t(20), size_t(28)}) EXPECT_EQ(image_bits_of_stream(mm.data(), n), 0) << n;
  const std::vector<uint8_t> png = file_bytes(dir + "/a16.png");
  EXPECT_EQ(image_bits_of_stream(png.data(), 24), 0);
  const uint8_t bmp[4] = {'B', 'M', 0, 0};
  EXPECT_EQ(image_bits_of_stream(bmp, 4), 0);
}

TEST(ImageBits, ARunOnSixteenBitPagesSaysTheyAreWrittenWithEight) {
  const std::string dir = tt::temp_dir();
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(3, 2, 64, dir + "/page.png");
  write_png16(dir + "/page.png", 64, 64, 40000);
  write_obj(m, dir + "/deep.obj");
  RunOptions ro;
  ro.input = dir + "/deep.obj";
  ro.output_dir = dir + "/out";
  const json report = run_pipeline(load_config(resolve_config("best")), ro);
  EXPECT_EQ(report["input_stats"]["page_bits_max"].get<int>(), 16);
  ASSERT_TRUE(report.contains("warnings"));
  ASSERT_EQ(report["warnings"].size(), 1u);
  const std::string w = report["warnings"][0].get<std::string>();
  EXPECT_NE(w.find("page.png, 16 bits"), std::string::npos) << w;
  EXPECT_NE(w.find("output pages have 8"), std::string::npos) << w;
  // 8-bit pages: no warning.
  write_image(dir + "/page.png", smooth_image(64, 64, 3), ImageFormat::Png);
  ro.output_dir = dir + "/out8";
  const json plain = run_pipeline(load_config(resolve_config("best")), ro);
  EXPECT_EQ(plain["input_stats"]["page_bits_max"].get<int>(), 8);
  EXPECT_FALSE(plain.contains("warnings"));
}

TEST(ImageCodec, JpegVariantsReadAsOpenImageIO) {
  const std::string dir = tt::temp_dir();
  struct Variant {
    const char* name;
    int components;
    J_COLOR_SPACE in, space;
    int h, v;
    bool progressive;
    int restart;
  };
  const std::vector<Variant> variants = {
      {"grey", 1, JCS_GRAYSCALE, JCS_GRAYSCALE, 1, 1, false, 0},
      {"grey_progressive", 1, JCS_GRAYSCALE, JCS_GRAYSCALE, 1, 1, true, 0},
      {"ycc444", 3, JCS_RGB, JCS_YCbCr, 1, 1, false, 0},
      {"ycc422", 3, JCS_RGB, JCS_YCbCr, 2, 1, false, 0},
      {"ycc420", 3, JCS_RGB, JCS_YCbCr, 2, 2, false, 0},
      {"ycc440", 3, JCS_RGB, JCS_YCbCr, 1, 2, false, 0},
      {"ycc411", 3, JCS_RGB, JCS_YCbCr, 4, 1, false, 0},
      {"ycc420_progressive", 3, JCS_RGB, JCS_YCbCr, 2, 2, true, 0},
      {"ycc420_restart", 3, JCS_RGB, JCS_YCbCr, 2, 2, false, 1},
      {"rgb", 3, JCS_RGB, JCS_RGB, 1, 1, false, 0},
      {"cmyk", 4, JCS_CMYK, JCS_CMYK, 1, 1, false, 0},
      {"ycck", 4, JCS_CMYK, JCS_YCCK, 2, 2, false, 0},
  };
  for (const Variant& v : variants)
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{37, 23}, {1, 1}, {64, 48}}) {
      it::RawJpeg j;
      j.width = w;
      j.height = h;
      j.components = v.components;
      j.in_space = v.in;
      j.space = v.space;
      j.h_samp = v.h;
      j.v_samp = v.v;
      j.progressive = v.progressive;
      j.restart_rows = v.restart;
      const Image smooth = smooth_image(std::max(w, 2), std::max(h, 2), v.components);
      const std::vector<uint8_t> grain = it::noise(smooth.pixels.size(), 3u);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < v.components; ++c)
            j.pixels.push_back(static_cast<uint8_t>(smooth.at(x, y)[c] + (grain[j.pixels.size()] & 31)));
      const std::string path = dir + "/" + v.name + "_" + std::to_string(w) + ".jpg";
      it::write_raw_jpeg(path, j);
      const Image want = it::oiio_read(path);
      expect_same_image(read_image(path), want, path);
      const std::vector<uint8_t> bytes = file_bytes(path);
      expect_same_image(decode_image(bytes.data(), bytes.size(), path), want, path + " (memory)");
    }
}

TEST(ImageCodec, JpegExifOrientationIsNotAppliedAsBefore) {
  // An APP1 EXIF block with Orientation = 6 (rotate 90 degrees) spliced in after SOI.
  const std::string dir = tt::temp_dir();
  const std::string plain = dir + "/plain.jpg", rotated = dir + "/rotated.jpg";
  write_image(plain, smooth_image(40, 24, 3), ImageFormat::Jpeg, 90);
  std::vector<uint8_t> b = file_bytes(plain);
  const std::vector<uint8_t> app1 = {0xFF, 0xE1, 0x00, 0x22, 'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0,
                                     1,    0,    0x12, 0x01, 3,   0,   1,   0,   0, 0, 6,   0,   0,  0, 0, 0, 0, 0};
  b.insert(b.begin() + 2, app1.begin(), app1.end());
  write_bytes(rotated, b, b.size());
  const Image got = read_image(rotated);
  EXPECT_EQ(got.width, 40);
  EXPECT_EQ(got.height, 24);
  expect_same_image(got, it::oiio_read(rotated), rotated);
  expect_same_image(got, read_image(plain), rotated + " vs the file without EXIF");
}

TEST(ImageCodec, JpegWritesTheBytesOpenImageIOWrote) {
  const std::string dir = tt::temp_dir();
  const std::pair<JpegSubsampling, const char*> subs[] = {
      {JpegSubsampling::S444, "4:4:4"}, {JpegSubsampling::S422, "4:2:2"}, {JpegSubsampling::S420, "4:2:0"}};
  for (int ch = 1; ch <= 4; ++ch)
    for (int q : {1, 50, 90, 95, 100})
      for (const auto& [s, name] : subs) {
        Image img = smooth_image(37, 29, ch);
        const std::vector<uint8_t> grain = it::noise(img.pixels.size(), 11u + q);
        for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<uint8_t>(img.pixels[i] + (grain[i] & 15));
        const std::string ours = dir + "/ours.jpg", theirs = dir + "/theirs.jpg";
        write_image(ours, img, ImageFormat::Jpeg, q, s);
        it::oiio_write(theirs, img, true, q, name);
        EXPECT_TRUE(file_bytes(ours) == file_bytes(theirs)) << ch << " channels, quality " << q << ", " << name;
      }
}

TEST(ImageCodec, PngWritesThePixelsOpenImageIOWrote) {
  const std::string dir = tt::temp_dir();
  for (int ch = 1; ch <= 4; ++ch) {
    Image img = smooth_image(300, 200, ch);
    const std::vector<uint8_t> grain = it::noise(img.pixels.size(), 21u + ch);
    for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<uint8_t>(img.pixels[i] + (grain[i] & 7));
    const std::string ours = dir + "/ours.png", theirs = dir + "/theirs.png";
    write_image(ours, img, ImageFormat::Png);
    it::oiio_write(theirs, img, false, 0, "");
    expect_same_image(it::oiio_read(ours), it::oiio_read(theirs), std::to_string(ch) + " channels");
    const double ratio = static_cast<double>(fs::file_size(ours)) / static_cast<double>(fs::file_size(theirs));
    RecordProperty("png_size_ratio_" + std::to_string(ch), std::to_string(ratio));
    EXPECT_LT(ratio, 1.05) << ch << " channels: " << fs::file_size(ours) << " vs " << fs::file_size(theirs);
  }
}

TEST(ImageCodec, TruncatedOrCorruptFilesAreErrorsNamingTheFileAndPrintNothing) {
  const std::string dir = tt::temp_dir();
  const Image img = noisy_image(64, 48, 3);
  for (const char* ext : {".png", ".jpg"}) {
    const std::string whole = dir + "/whole" + ext;
    write_image(whole, img, ext == std::string(".png") ? ImageFormat::Png : ImageFormat::Jpeg, 90);
    const std::vector<uint8_t> b = file_bytes(whole);
    for (size_t cut : {size_t{3}, size_t{9}, size_t{30}, size_t{120}, b.size() / 2, b.size() - 20, b.size() - 2}) {
      const std::string p = dir + "/cut" + std::to_string(cut) + ext;
      write_bytes(p, b, cut);
      std::string msg;
      const std::string printed = stderr_of([&] { msg = image_error([&] { read_image(p); }); });
      EXPECT_EQ(msg.rfind(p + ": ", 0), 0u) << msg;
      EXPECT_EQ(printed, "") << p;
      if (cut <= 30) {
        const std::string printed2 = stderr_of([&] {
          int w, h;
          msg = image_error([&] { read_image_size(p, w, h); });
        });
        EXPECT_EQ(msg.rfind(p + ": ", 0), 0u) << msg;
        EXPECT_EQ(printed2, "") << p;
      }
      EXPECT_THROW(decode_image(b.data(), cut, "mem"), ImageError) << cut;
    }
  }
  // A flipped byte in the PNG's pixel data breaks its CRC: an error, not other pixels.
  const std::string whole = dir + "/whole.png";
  std::vector<uint8_t> b = file_bytes(whole);
  b[b.size() / 2] ^= 0x55;
  const std::string p = dir + "/flipped.png";
  write_bytes(p, b, b.size());
  EXPECT_EQ(image_error([&] { read_image(p); }).rfind(p + ": ", 0), 0u);
}
