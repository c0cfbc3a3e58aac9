// Every real PNG/JPEG page decodes to the pixels OpenImageIO 2.4 gave (the reader before PNG and
// JPEG had their own codecs): the six development tiles, the bundled examples, the Cedar Creek
// JPEG pages (the stand-ins of its GLBs' KTX2 textures), the YCB banana's 4096^2 PNG and the
// M-method's PNG outputs, i.e. every .jpg/.jpeg/.png under the shared data folder.
#include "image_test_util.h"

#include "texdefrag/io/image.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

std::vector<std::string> pages_under(const fs::path& root) {
  std::vector<std::string> out;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    std::string e = it->path().extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (e == ".jpg" || e == ".jpeg" || e == ".png") out.push_back(it->path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

void compare_all(const std::vector<std::string>& pages) {
  for (const std::string& p : pages) {
    const Image want = image_test::oiio_read(p);
    const Image got = read_image(p);
    EXPECT_EQ(got.width, want.width) << p;
    EXPECT_EQ(got.height, want.height) << p;
    EXPECT_EQ(got.channels, want.channels) << p;
    EXPECT_TRUE(got.pixels == want.pixels) << p << ": pixels differ";
  }
}

}  // namespace

TEST(ImageReal, BundledExamplePagesDecodeAsOpenImageIO) {
  const std::vector<std::string> pages = pages_under(fs::path(source_dir()) / "examples");
  ASSERT_FALSE(pages.empty());
  compare_all(pages);
  RecordProperty("pages", static_cast<int>(pages.size()));
}

TEST(ImageReal, EveryPageOfTheSharedDataDecodesAsOpenImageIO) {
  TEXDEFRAG_REQUIRE_DATA(root, "contextcapture");
  const std::vector<std::string> pages = pages_under(fs::path(root).parent_path());
  size_t jpeg = 0, png = 0;
  for (const std::string& p : pages) (p.back() == 'g' && p[p.size() - 2] == 'n' ? png : jpeg)++;
  std::printf("comparing %zu JPEG and %zu PNG pages under %s\n", jpeg, png, fs::path(root).parent_path().c_str());
  EXPECT_GE(jpeg, 50u);
  compare_all(pages);
  RecordProperty("jpeg_pages", static_cast<int>(jpeg));
  RecordProperty("png_pages", static_cast<int>(png));
}
