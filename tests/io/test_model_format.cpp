// The ModelFormat interface: dispatch by input, the OBJ format's round trip through it, page
// encodings (JPEG quality from the quantisation tables) and the default output page format.
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Image gradient(int w, int h) {
  Image img;
  img.width = w;
  img.height = h;
  img.channels = 3;
  img.pixels.resize(static_cast<size_t>(w * h * 3));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = static_cast<uint8_t>(x * 255 / w);
      p[1] = static_cast<uint8_t>(y * 255 / h);
      p[2] = static_cast<uint8_t>((x ^ y) & 0xFF);
    }
  return img;
}

}  // namespace

TEST(ModelFormat, DispatchesByInput) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string obj = dir + "/m.OBJ";
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_EQ(format_for_input(obj).name(), "obj");
  const std::string other = dir + "/m.xyz";
  std::ofstream(other) << "1 2 3\n";
  try {
    format_for_input(other);
    ADD_FAILURE() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find(other + ": no model format reads this file (known formats: obj"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(format_for_input(dir + "/missing.obj"), FormatError);
  ASSERT_NE(find_model_format("obj"), nullptr);
  EXPECT_EQ(find_model_format("nope"), nullptr);
}

TEST(JpegQuality, RecoversTheEncoderQuality) {
  const std::string dir = texdefrag::testing::temp_dir();
  for (int q : {10, 50, 75, 85, 90, 95, 100}) {
    const std::string path = dir + "/q" + std::to_string(q) + ".jpg";
    write_image(path, gradient(64, 48), ImageFormat::Jpeg, q);
    const auto est = estimate_jpeg_quality_of_file(path);
    ASSERT_TRUE(est.has_value()) << path;
    EXPECT_EQ(*est, q) << path;
    const PageEncoding e = page_encoding_of_file(path);
    EXPECT_EQ(e.format, "jpeg");
    EXPECT_EQ(e.bytes, fs::file_size(path));
  }
  const std::string png = dir + "/p.png";
  write_image(png, gradient(8, 8), ImageFormat::Png);
  EXPECT_FALSE(estimate_jpeg_quality_of_file(png).has_value());
  EXPECT_EQ(page_encoding_of_file(png).format, "png");
  const uint8_t truncated[] = {0xFF, 0xD8, 0xFF, 0xDB, 0x00, 0x43, 0x00, 0x01};
  EXPECT_FALSE(estimate_jpeg_quality(truncated, sizeof truncated).has_value());
}

TEST(ModelFormat, PageFormatFollowsTheInput) {
  LoadedModel m;
  m.mesh.pages.resize(2);
  m.mesh.faces.resize(2);
  m.mesh.faces[0].page = 0;
  m.mesh.faces[1].page = 1;
  m.page_encodings = {{"jpeg", 80, 100}, {"jpeg", 87, 100}};
  PageWriteOptions o = choose_page_options(m, "input", 95, true);
  EXPECT_EQ(o.format, ImageFormat::Jpeg);
  EXPECT_EQ(o.jpeg_quality, 87);  // the largest input quality
  o = choose_page_options(m, "input", 60, false);
  EXPECT_EQ(o.jpeg_quality, 60);
  EXPECT_EQ(choose_page_options(m, "png", 95, true).format, ImageFormat::Png);
  m.page_encodings[1] = {"png", std::nullopt, 100};
  EXPECT_EQ(choose_page_options(m, "input", 95, true).format, ImageFormat::Png);  // mixed: lossless
  m.mesh.faces[1].page = kNoPage;  // the PNG page is not used by any face
  EXPECT_EQ(choose_page_options(m, "input", 95, true).format, ImageFormat::Jpeg);
  EXPECT_EQ(choose_page_options(m, "jpeg", 95, false).jpeg_quality, 95);
  EXPECT_THROW(choose_page_options(m, "webp", 95, true), FormatError);
}

TEST(ModelFormat, ObjWritesWhatWriteObjWrites) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string img = dir + "/in/tex.png";
  fs::create_directories(dir + "/in");
  texdefrag::testing::write_test_image(img, 16, 16);
  TexturedMesh mesh = texdefrag::testing::grid_mesh(2, 2, 16, img);
  write_obj(mesh, dir + "/in/grid.obj");

  const ModelFormat& format = format_for_input(dir + "/in/grid.obj");
  const LoadedModel in = format.read(dir + "/in/grid.obj");
  EXPECT_EQ(in.format, "obj");
  ASSERT_EQ(in.page_encodings.size(), 1u);
  EXPECT_EQ(in.page_encodings[0].format, "png");
  EXPECT_EQ(in.input_files.front(), dir + "/in/grid.obj");
  const Image page = in.page_image(0);
  EXPECT_EQ(page.width, 16);

  TexturedMesh out = in.mesh;
  out.pages[0].image_path = dir + "/out/grid_page0.png";
  OutputSet files(dir + "/out", in.input_files);
  const WriteResult r = format.write(in, out, {page}, "grid", PageWriteOptions{}, files);
  files.commit();
  EXPECT_EQ(r.main_file, dir + "/out/grid.obj");
  EXPECT_EQ(r.files.size(), 3u);  // obj, mtl, page
  EXPECT_EQ(r.page_bytes, fs::file_size(dir + "/out/grid_page0.png"));
  fs::create_directories(dir + "/direct");
  write_obj(out, dir + "/direct/grid.obj");
  EXPECT_EQ(slurp(dir + "/out/grid.obj"), slurp(dir + "/direct/grid.obj"));
  EXPECT_EQ(slurp(dir + "/out/grid.mtl"), slurp(dir + "/direct/grid.mtl"));

  // Writing onto an input is refused, naming the file.
  OutputSet onto_input(dir + "/in", in.input_files);
  try {
    format.write(in, in.mesh, {page}, "grid", PageWriteOptions{}, onto_input);
    ADD_FAILURE() << "expected a refusal";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("tex.png"), std::string::npos) << e.what();
  }
}
