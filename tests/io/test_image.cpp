// Image IO: PNG round trip exact, JPEG close, header-only size, 16-bit/TIFF input converted to
// 8 bits, atomic writes, and errors that name the file.
#include "io_test_util.h"

#include "texdefrag/io/image.h"
#include "texdefrag/testing/fixtures.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
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
