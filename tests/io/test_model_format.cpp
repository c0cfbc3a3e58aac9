// The ModelFormat interface: dispatch by input, the OBJ format's round trip through it, page
// encodings (JPEG quality from the quantisation tables) and the default output page format.
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/io/gltf_format.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj_format.h"
#include "texdefrag/io/osgb.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/parallel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

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

/// Four textured faces on one page: a right triangle, a sliver whose apex lies 1e-9 above its
/// base at v = 0.5 (a float32 cannot tell 0.5 + 1e-9 from 0.5: the sliver collapses when stored),
/// a face of zero UV area, and one clockwise.
TexturedMesh four_faces_for_read_back() {
  TexturedMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.texcoords = {{0.1, 0.1}, {0.3, 0.1}, {0.1, 0.3},               // right triangle
                 {0.5, 0.5}, {0.75, 0.5}, {0.6, 0.5 + 1e-9},       // sliver
                 {0.2, 0.7}, {0.3, 0.7}, {0.4, 0.7},               // zero area
                 {0.8, 0.8}, {0.8, 0.9}, {0.9, 0.8}};              // clockwise
  for (int k = 0; k < 4; ++k) {
    Face f;
    f.v = {0, 1, 2};
    f.vt = {3 * k, 3 * k + 1, 3 * k + 2};
    m.faces.push_back(f);
  }
  return m;
}

TEST(ModelFormat, FacesTurnedByTheStoredTexcoordsAreCounted) {
  const TexturedMesh in = four_faces_for_read_back();
  TexturedMesh m = in;
  EXPECT_EQ(faces_turned_by(in, m, [](const Vec2& t) { return t; }), 0u);
  // OBJ prints doubles exactly: nothing turns.
  EXPECT_EQ(faces_turned_by(in, m, ObjFormat().texcoord_read_back({})), 0u);
  // OSGB and glTF store float32: the sliver collapses (counted), the zero-area face is not counted.
  EXPECT_EQ(faces_turned_by(in, m, OsgbFormat().texcoord_read_back({})), 1u);
  EXPECT_EQ(faces_turned_by(in, m, GltfFormat().texcoord_read_back({})), 1u);
  // A mirror of every coordinate turns the two faces of nonzero area that survive rounding too.
  EXPECT_EQ(faces_turned_by(in, m, [](const Vec2& t) { return Vec2(-t.x(), t.y()); }), 3u);
  // A face of zero UV area in the input is not counted, whatever the output makes of it: here the
  // input's sliver is flattened and the output keeps it thin (the sliver again).
  TexturedMesh flat_in = in;
  flat_in.texcoords[5] = {0.6, 0.5};
  EXPECT_EQ(faces_turned_by(flat_in, m, OsgbFormat().texcoord_read_back({})), 0u);
}

TEST(ModelFormat, StoredAsFloat32Rounds) {
  // Two values side by side, as the read-backs round them (the pair GCC 12.2 -O3 folded away).
  const Vec2 t(0.6, 0.5 + 1e-9);
  const Vec2 r(stored_as_float32(t.x()), stored_as_float32(t.y()));
  EXPECT_EQ(r.x(), static_cast<double>(0.6f));
  EXPECT_NE(r.x(), 0.6);
  EXPECT_EQ(r.y(), 0.5);
}

TEST(ModelFormat, GltfStoresTexcoordsAsFloatsWithVFromTheTop) {
  const TexcoordReadBack rb = GltfFormat().texcoord_read_back({});
  ASSERT_TRUE(rb);
  // 1 - 0.3 = 0.7 is stored as the float nearest 0.7; read back, 1 - that.
  const Vec2 t = rb(Vec2(0.1, 0.3));
  EXPECT_EQ(t.x(), static_cast<double>(0.1f));
  EXPECT_EQ(t.y(), 1.0 - static_cast<double>(0.7f));
  // Draco-quantised output: the grid is the encoder's, so the format does not say.
  PageWriteOptions po;
  po.output_options = {{"draco", "quantized"}};
  EXPECT_FALSE(GltfFormat().texcoord_read_back(po));
  po.output_options = {{"draco", "lossless"}};
  EXPECT_TRUE(GltfFormat().texcoord_read_back(po));
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
  m.page_encodings = {{"jpeg", 80, 100, std::nullopt}, {"jpeg", 87, 100, std::nullopt}};
  PageWriteOptions o = choose_page_options(m, "input", 95, true);
  EXPECT_EQ(o.format, ImageFormat::Jpeg);
  EXPECT_EQ(o.jpeg_quality, 87);  // the largest input quality
  o = choose_page_options(m, "input", 60, false);
  EXPECT_EQ(o.jpeg_quality, 60);
  EXPECT_EQ(choose_page_options(m, "png", 95, true).format, ImageFormat::Png);
  m.page_encodings[1] = {"png", std::nullopt, 100, std::nullopt};
  EXPECT_EQ(choose_page_options(m, "input", 95, true).format, ImageFormat::Png);  // mixed: lossless
  m.mesh.faces[1].page = kNoPage;  // the PNG page is not used by any face
  EXPECT_EQ(choose_page_options(m, "input", 95, true).format, ImageFormat::Jpeg);
  EXPECT_EQ(choose_page_options(m, "jpeg", 95, false).jpeg_quality, 95);
  EXPECT_THROW(choose_page_options(m, "webp", 95, true), FormatError);
}

TEST(JpegSubsampling, ReadFromTheFrameHeader) {
  const std::string dir = texdefrag::testing::temp_dir();
  for (JpegSubsampling s : {JpegSubsampling::S444, JpegSubsampling::S422, JpegSubsampling::S420}) {
    const std::string path = dir + "/s" + std::to_string(static_cast<int>(s)) + ".jpg";
    write_image(path, gradient(64, 48), ImageFormat::Jpeg, 90, s);
    EXPECT_EQ(read_jpeg_subsampling_of_file(path), s) << jpeg_subsampling_name(s);
    EXPECT_EQ(page_encoding_of_file(path).jpeg_subsampling, s);
  }
  // write_image's default is libjpeg's own 4:2:0 (the pipeline passes output.jpeg_subsampling).
  write_image(dir + "/default.jpg", gradient(64, 48), ImageFormat::Jpeg, 90);
  EXPECT_EQ(read_jpeg_subsampling_of_file(dir + "/default.jpg"), JpegSubsampling::S420);
  // Not a JPEG, truncated before the SOF, a grey image: unknown.
  write_image(dir + "/p.png", gradient(8, 8), ImageFormat::Png);
  EXPECT_FALSE(read_jpeg_subsampling_of_file(dir + "/p.png").has_value());
  const uint8_t truncated[] = {0xFF, 0xD8, 0xFF, 0xDB, 0x00, 0x43, 0x00, 0x01};
  EXPECT_FALSE(read_jpeg_subsampling(truncated, sizeof truncated).has_value());
  Image grey = gradient(16, 16);
  grey.channels = 1;
  grey.pixels.resize(16 * 16);
  write_image(dir + "/grey.jpg", grey, ImageFormat::Jpeg, 90, JpegSubsampling::S420);
  EXPECT_FALSE(read_jpeg_subsampling_of_file(dir + "/grey.jpg").has_value());
}

// Colour detail at the texel scale (alternating red and blue columns, as saturated vegetation
// or roof edges in an atlas) survives 4:4:4 and is lost by 4:2:0 at the same quality.
TEST(JpegSubsampling, FourFourFourKeepsColourDetail) {
  const std::string dir = texdefrag::testing::temp_dir();
  Image img = gradient(64, 64);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = x % 2 ? 200 : 30;
      p[1] = 90;
      p[2] = x % 2 ? 30 : 200;
    }
  auto error = [&](JpegSubsampling s) {
    const std::string path = dir + "/c" + std::to_string(static_cast<int>(s)) + ".jpg";
    write_image(path, img, ImageFormat::Jpeg, 100, s);
    const Image back = read_image(path);
    double e = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) e += std::abs(int(back.pixels[i]) - int(img.pixels[i]));
    return e / static_cast<double>(img.pixels.size());
  };
  const double e444 = error(JpegSubsampling::S444), e420 = error(JpegSubsampling::S420);
  EXPECT_LT(e444, 3.0);
  EXPECT_GT(e420, 10 * e444) << e444 << " vs " << e420;
}

TEST(ModelFormat, JpegSubsamplingIsForcedOrTheInputs) {
  LoadedModel m;
  m.mesh.pages.resize(2);
  m.mesh.faces.resize(2);
  m.mesh.faces[0].page = 0;
  m.mesh.faces[1].page = 1;
  m.page_encodings = {{"jpeg", 90, 100, JpegSubsampling::S420}, {"jpeg", 90, 100, JpegSubsampling::S422}};
  EXPECT_EQ(choose_page_options(m, "input", 95, true).jpeg_subsampling, JpegSubsampling::S444);  // the default
  EXPECT_EQ(choose_page_options(m, "input", 95, true, "4:2:0").jpeg_subsampling, JpegSubsampling::S420);
  EXPECT_EQ(choose_page_options(m, "input", 95, true, "input").jpeg_subsampling, JpegSubsampling::S422);  // finest
  m.mesh.faces[1].page = kNoPage;  // only textured pages count
  EXPECT_EQ(choose_page_options(m, "input", 95, true, "input").jpeg_subsampling, JpegSubsampling::S420);
  m.page_encodings[0].jpeg_subsampling.reset();  // unknown: 4:4:4
  EXPECT_EQ(choose_page_options(m, "input", 95, true, "input").jpeg_subsampling, JpegSubsampling::S444);
  EXPECT_THROW(choose_page_options(m, "input", 95, true, "4:1:1"), FormatError);
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

namespace {

/// A textured page: gradient plus deterministic noise (so JPEG bytes grow with quality).
Image noisy(int w, int h, unsigned seed) {
  Image img = gradient(w, h);
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    seed = seed * 1103515245u + 12345u;
    img.pixels[i] = static_cast<uint8_t>((img.pixels[i] + ((seed >> 16) % 48)) & 0xFF);
  }
  return img;
}

size_t total_jpeg_bytes(const std::vector<const Image*>& pages, int q) {
  size_t n = 0;
  for (const Image* p : pages) n += encode_jpeg(*p, q, JpegSubsampling::S444).size();
  return n;
}

}  // namespace

// encode_jpeg gives the bytes write_image writes.
TEST(JpegQualityFit, EncodeJpegIsWhatWriteImageWrites) {
  const std::string dir = texdefrag::testing::temp_dir();
  const Image img = noisy(40, 24, 1);
  for (JpegSubsampling s : {JpegSubsampling::S444, JpegSubsampling::S420}) {
    write_image(dir + "/a.jpg", img, ImageFormat::Jpeg, 91, s);
    const std::vector<uint8_t> mem = encode_jpeg(img, 91, s);
    EXPECT_EQ(std::string(mem.begin(), mem.end()), slurp(dir + "/a.jpg"));
  }
  EXPECT_THROW(encode_jpeg(img, 0, JpegSubsampling::S444), ImageError);
  EXPECT_THROW(encode_jpeg(Image{}, 90, JpegSubsampling::S444), ImageError);
}

// The search's invariants on small pages, for budgets between every pair of qualities: the bytes
// reported are those measured at the quality chosen and within the cap; the next quality up is
// over the cap; the same answer with 1 and 2 threads; the floor is never lowered.
TEST(JpegQualityFit, HighestQualityWithinTheBytesCapDeterministically) {
  const Image a = noisy(64, 48, 7), b = noisy(33, 70, 9);
  const std::vector<const Image*> pages = {&a, &b};
  std::vector<size_t> bytes(101, 0);
  for (int q = 70; q <= 100; ++q) bytes[static_cast<size_t>(q)] = total_jpeg_bytes(pages, q);
  for (int q = 70; q < 100; ++q) {
    const size_t budget = bytes[static_cast<size_t>(q)] + 1;
    set_thread_count(1);
    const JpegQualityFit one = fit_jpeg_quality(pages, 70, 100, JpegSubsampling::S444, budget);
    set_thread_count(2);
    const JpegQualityFit two = fit_jpeg_quality(pages, 70, 100, JpegSubsampling::S444, budget);
    ASSERT_TRUE(one.within_budget) << q;
    EXPECT_LE(one.bytes, budget) << q;
    EXPECT_EQ(one.bytes, bytes[static_cast<size_t>(one.quality)]) << q;
    EXPECT_GE(one.quality, q) << q;  // q itself fits
    if (one.quality < 100) {
      EXPECT_GT(bytes[static_cast<size_t>(one.quality) + 1], budget) << q;
    }
    EXPECT_EQ(one.quality, two.quality) << q;
    EXPECT_EQ(one.bytes, two.bytes) << q;
    EXPECT_EQ(one.probes, two.probes) << q;
    EXPECT_LE(one.probes, 2 + 3 * 4) << q;
  }
  set_thread_count(0);
  const JpegQualityFit all = fit_jpeg_quality(pages, 70, 100, JpegSubsampling::S444, bytes[100]);
  EXPECT_EQ(all.quality, 100);
  EXPECT_EQ(all.probes, 2);  // both ends are encoded in the first round
  const JpegQualityFit none = fit_jpeg_quality(pages, 70, 100, JpegSubsampling::S444, bytes[70] - 1);
  EXPECT_EQ(none.quality, 70);  // never below the floor
  EXPECT_FALSE(none.within_budget);
  EXPECT_EQ(none.bytes, bytes[70]);
  EXPECT_THROW(fit_jpeg_quality(pages, 90, 80, JpegSubsampling::S444, 1), ImageError);
}

std::vector<uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The highest quality whose measured bytes fit: `bytes` holds every quality's total.
int highest_fitting(const std::vector<size_t>& bytes, int lo, size_t budget) {
  int best = lo;
  for (int q = lo; q <= 100; ++q)
    if (bytes[static_cast<size_t>(q)] <= budget) best = q;
  return best;
}

// Pages of 2048 rows or more are predicted on a sample, then measured whole: the answer is the
// same as a search over whole pages would give (bytes here grow with quality), with 1 and 2
// threads alike, and the whole pages are encoded at a handful of qualities, not a bisection's 11.
// (This page's XOR pattern varies band to band, so its sample predicts 0-3 qualities low.)
TEST(JpegQualityFit, TallPagesArePredictedOnSamplesAndMeasuredWhole) {
  const Image tall = noisy(40, 2200, 3), small = noisy(33, 70, 9);
  const std::vector<const Image*> pages = {&tall, &small};
  std::vector<size_t> bytes(101, 0);
  for (int q = 60; q <= 100; ++q) bytes[static_cast<size_t>(q)] = total_jpeg_bytes(pages, q);
  for (int q = 60; q <= 100; ++q) ASSERT_GE(bytes[static_cast<size_t>(q)], bytes[static_cast<size_t>(q) - 1]) << q;
  for (int q = 60; q < 100; q += 3) {
    const size_t budget = bytes[static_cast<size_t>(q)] + 1;
    set_thread_count(1);
    const JpegQualityFit one = fit_jpeg_quality(pages, 60, 100, JpegSubsampling::S444, budget);
    set_thread_count(2);
    const JpegQualityFit two = fit_jpeg_quality(pages, 60, 100, JpegSubsampling::S444, budget);
    EXPECT_EQ(one.quality, highest_fitting(bytes, 60, budget)) << q;
    EXPECT_EQ(one.bytes, bytes[static_cast<size_t>(one.quality)]) << q;
    EXPECT_TRUE(one.within_budget) << q;
    EXPECT_GT(one.sample_probes, 0) << q;
    EXPECT_LE(one.probes, 6) << q;  // a whole-page search from the ends encodes 8-11 qualities here
    EXPECT_EQ(one.quality, two.quality) << q;
    EXPECT_EQ(one.probes, two.probes) << q;
    EXPECT_EQ(one.sample_probes, two.sample_probes) << q;
    // The answer's streams are kept for the writer: exactly what encoding the pages gives.
    ASSERT_EQ(one.streams.size(), 2u) << q;
    EXPECT_EQ(one.streams[0], encode_jpeg(tall, one.quality, JpegSubsampling::S444)) << q;
    EXPECT_EQ(one.streams[1], encode_jpeg(small, one.quality, JpegSubsampling::S444)) << q;
  }
  set_thread_count(0);
}

// write_page writes the kept stream when there is one, and encodes the page otherwise; a count of
// streams that is not the count of pages is refused, naming the file.
TEST(JpegQualityFit, WritePageWritesTheKeptStreamOrEncodes) {
  const fs::path dir = texdefrag::testing::temp_dir();
  const std::vector<Image> pages = {noisy(24, 16, 2)};
  PageWriteOptions po;
  po.format = ImageFormat::Jpeg;
  po.jpeg_quality = 80;
  write_page((dir / "a.jpg").string(), pages, 0, po);
  EXPECT_EQ(read_bytes(dir / "a.jpg"), encode_jpeg(pages[0], 80, po.jpeg_subsampling));
  po.encoded = {{0xFF, 0xD8, 1, 2, 3}};  // not a real JPEG: proves the kept bytes are what is written
  write_page((dir / "b.jpg").string(), pages, 0, po);
  EXPECT_EQ(read_bytes(dir / "b.jpg"), po.encoded[0]);
  EXPECT_EQ(encode_page(pages, 0, po), po.encoded[0]);
  po.encoded.push_back({1});
  EXPECT_THROW(write_page((dir / "c.jpg").string(), pages, 0, po), ImageError);
}

// A sample can mislead: here every sampled band (jpeg_fit_sample_bands) is flat and the rest is
// noise, so the sample predicts far too few bytes. The search from the prediction still steps
// down to the measured answer; a floor that does not fit is kept and reported as over.
TEST(JpegQualityFit, AMisleadingSampleDoesNotChangeTheAnswer) {
  Image page = noisy(32, 2048, 5);
  for (const auto& [y0, rows] : jpeg_fit_sample_bands(page.height))
    for (int y = y0; y < y0 + rows; ++y)
      for (int x = 0; x < page.width; ++x)
        for (int c = 0; c < page.channels; ++c) page.at(x, y)[c] = 128;
  const std::vector<const Image*> pages = {&page};
  std::vector<size_t> bytes(101, 0);
  for (int q = 50; q <= 100; ++q) bytes[static_cast<size_t>(q)] = total_jpeg_bytes(pages, q);
  for (int q : {50, 62, 75, 88, 97}) {
    const size_t budget = bytes[static_cast<size_t>(q)];
    const JpegQualityFit fit = fit_jpeg_quality(pages, 50, 100, JpegSubsampling::S444, budget);
    EXPECT_EQ(fit.quality, highest_fitting(bytes, 50, budget)) << q;
    EXPECT_EQ(fit.bytes, bytes[static_cast<size_t>(fit.quality)]) << q;
    EXPECT_TRUE(fit.within_budget) << q;
    EXPECT_GT(fit.probes, 2) << q;  // the prediction (100) was over: it stepped down
  }
  const JpegQualityFit none = fit_jpeg_quality(pages, 50, 100, JpegSubsampling::S444, bytes[50] - 1);
  EXPECT_EQ(none.quality, 50);
  EXPECT_FALSE(none.within_budget);
  EXPECT_EQ(none.bytes, bytes[50]);
}

// fit_page_quality raises only a quality matched from the input, up to max_quality, against the
// input's page bytes; the options that fix the quality are left alone.
TEST(JpegQualityFit, PageQualityIsRaisedOnlyFromTheInputsEstimate) {
  const Image page = noisy(64, 64, 3);
  const size_t q80 = encode_jpeg(page, 80, JpegSubsampling::S444).size();
  const size_t q95 = encode_jpeg(page, 95, JpegSubsampling::S444).size();
  LoadedModel m;
  m.mesh.pages.resize(1);
  m.mesh.faces.resize(1);
  m.mesh.faces[0].page = 0;
  m.page_encodings = {{"jpeg", 80, q95, JpegSubsampling::S420}};
  const std::vector<Image> out = {page};
  PageWriteOptions po = choose_page_options(m, "input", 60, true);
  EXPECT_TRUE(po.jpeg_quality_from_input);
  JpegQualityFit fit = fit_page_quality(m, out, po, 100);
  EXPECT_GE(po.jpeg_quality, 95);
  EXPECT_LT(po.jpeg_quality, 100);
  EXPECT_LE(fit.bytes, q95);
  po = choose_page_options(m, "input", 60, true);
  fit_page_quality(m, out, po, 90);  // capped
  EXPECT_EQ(po.jpeg_quality, 90);
  po = choose_page_options(m, "input", 60, true);
  EXPECT_EQ(fit_page_quality(m, out, po, 80).probes, 0);  // the cap is the estimate: nothing to raise
  EXPECT_EQ(po.jpeg_quality, 80);
  po = choose_page_options(m, "input", 60, false);  // the quality option, not the input's
  EXPECT_EQ(fit_page_quality(m, out, po, 100).probes, 0);
  EXPECT_EQ(po.jpeg_quality, 60);
  po = choose_page_options(m, "png", 60, true);
  EXPECT_EQ(fit_page_quality(m, out, po, 100).probes, 0);
  m.page_encodings[0].bytes = q80 - 1;  // even the estimate is over: kept, never lowered
  po = choose_page_options(m, "input", 60, true);
  fit = fit_page_quality(m, out, po, 100);
  EXPECT_EQ(po.jpeg_quality, 80);
  EXPECT_FALSE(fit.within_budget);
  m.page_encodings[0].bytes = 0;  // unknown input bytes: nothing to fit against
  po = choose_page_options(m, "input", 60, true);
  EXPECT_EQ(fit_page_quality(m, out, po, 100).probes, 0);
  EXPECT_EQ(po.jpeg_quality, 80);
}

namespace {

/// The first quantisation table of a JPEG stream (DQT, 8-bit), in natural order.
std::vector<int> first_dqt(const std::vector<uint8_t>& jpeg) {
  for (size_t i = 2; i + 4 + 65 <= jpeg.size(); ++i)
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xDB) {
      const int zigzag[64] = {0,  1,  8,  16, 9,  2,  3,  10, 17, 24, 32, 25, 18, 11, 4,  5,  12, 19, 26, 33, 40, 48,
                              41, 34, 27, 20, 13, 6,  7,  14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
                              30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};
      std::vector<int> t(64);
      for (int k = 0; k < 64; ++k) t[static_cast<size_t>(zigzag[k])] = jpeg[i + 5 + static_cast<size_t>(k)];
      return t;
    }
  return {};
}

bool has_marker(const std::vector<uint8_t>& jpeg, uint8_t marker) {
  for (size_t i = 0; i + 1 < jpeg.size(); ++i)
    if (jpeg[i] == 0xFF && jpeg[i + 1] == marker) return true;
  return false;
}

/// Mean squared error over every channel of two images of the same size.
double mse(const Image& a, const Image& b) {
  double s = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - static_cast<double>(b.pixels[i]);
    s += d * d;
  }
  return s / static_cast<double>(a.pixels.size());
}

/// A photo-like page: smooth shading, sharp-edged patches and texel noise (as atlases of scans).
Image photo_like(int w, int h, unsigned seed) {
  Image img = gradient(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* p = img.at(x, y);
      const bool patch = ((x / 11) + (y / 7)) % 3 == 0;
      for (int c = 0; c < 3; ++c) {
        seed = seed * 1103515245u + 12345u;
        const int v = (p[c] / 2 + (patch ? 90 : 20) + c * 15 + static_cast<int>((seed >> 16) % 24));
        p[c] = static_cast<uint8_t>(std::min(v, 255));
      }
    }
  return img;
}

}  // namespace

// Flat tables: one step for every coefficient, 16 x the quality scaling as a real number (floor for
// the lowest frequencies, ceiling for the rest, mean exact); both tables the same; 97-100 are step 1.
TEST(JpegTables, FlatTableStepsAreTheScaledBase) {
  const Image img = noisy(40, 24, 5);
  for (int q : {30, 50, 85, 90, 96, 100}) {
    const std::vector<int> t = first_dqt(encode_jpeg(img, q, JpegSubsampling::S444, "p", {JpegTables::Flat, false}));
    ASSERT_EQ(t.size(), 64u) << q;
    const double scale = q < 50 ? 5000 / q : 200 - 2 * q;  // libjpeg's jpeg_quality_scaling (integers)
    const double step = std::max(1.0, 16.0 * scale / 100.0);
    double sum = 0;
    for (int v : t) {
      EXPECT_TRUE(v == static_cast<int>(step) || v == static_cast<int>(step) + 1) << q << " step " << v;
      sum += v;
    }
    EXPECT_NEAR(sum / 64, step, 0.5 / 64 + 1e-9) << q;
    EXPECT_LE(t[0], t[63]) << q;  // the DC takes the floor
  }
  // The standard tables stay libjpeg's: q50 is Annex K itself (luminance DC 16, corner 99).
  const std::vector<int> s = first_dqt(encode_jpeg(img, 50, JpegSubsampling::S444));
  EXPECT_EQ(s[0], 16);
  EXPECT_EQ(s[63], 99);
}

// Progressive scans (SOF2) decode to exactly the pixels of the baseline file with the same tables,
// in fewer bytes on a textured page; the default coding is baseline (SOF0).
TEST(JpegTables, ProgressiveIsTheSamePixelsInFewerBytes) {
  const Image img = photo_like(96, 64, 11);
  for (JpegTables tables : {JpegTables::Standard, JpegTables::Flat}) {
    const std::vector<uint8_t> base = encode_jpeg(img, 90, JpegSubsampling::S444, "p", {tables, false});
    const std::vector<uint8_t> prog = encode_jpeg(img, 90, JpegSubsampling::S444, "p", {tables, true});
    EXPECT_TRUE(has_marker(base, 0xC0));
    EXPECT_FALSE(has_marker(base, 0xC2));
    EXPECT_TRUE(has_marker(prog, 0xC2));
    EXPECT_LT(prog.size(), base.size());
    const Image a = decode_image(base.data(), base.size(), "base"), b = decode_image(prog.data(), prog.size(), "prog");
    EXPECT_EQ(a.pixels, b.pixels);
  }
  const std::string dir = texdefrag::testing::temp_dir();
  write_image(dir + "/p.jpg", img, ImageFormat::Jpeg, 90, JpegSubsampling::S444, {JpegTables::Flat, true});
  const std::string file = slurp(dir + "/p.jpg");
  const std::vector<uint8_t> mem = encode_jpeg(img, 90, JpegSubsampling::S444, "p", {JpegTables::Flat, true});
  EXPECT_EQ(file, std::string(mem.begin(), mem.end()));  // write_image writes what encode_jpeg measured
}

// The reason flat tables are the pages' default: at the bytes the standard tables spend at a high
// quality (90-95, where pages of quality-90 inputs are fitted), the flat tables' best fitting
// quality is closer to the page (squared error, as PSNR). Not at any rate: on this page at the
// bytes of standard quality 85 the flat tables are 0.13 dB worse (low frequencies then matter more).
TEST(JpegTables, FlatTablesGiveLessErrorAtTheSameBytes) {
  const Image img = photo_like(128, 96, 3);
  for (int q : {90, 93, 95}) {
    const std::vector<uint8_t> std_jpeg = encode_jpeg(img, q, JpegSubsampling::S444, "p", {JpegTables::Standard, true});
    const JpegQualityFit fit = fit_jpeg_quality({&img}, 1, 100, JpegSubsampling::S444, std_jpeg.size(),
                                                {JpegTables::Flat, true});
    ASSERT_TRUE(fit.within_budget) << q;
    const std::vector<uint8_t> flat = encode_jpeg(img, fit.quality, JpegSubsampling::S444, "p", {JpegTables::Flat, true});
    EXPECT_EQ(flat.size(), fit.bytes);
    const double e_std = mse(img, decode_image(std_jpeg.data(), std_jpeg.size(), "s"));
    const double e_flat = mse(img, decode_image(flat.data(), flat.size(), "f"));
    EXPECT_LT(e_flat, e_std) << q << ": flat q" << fit.quality << " " << flat.size() << " bytes vs " << std_jpeg.size();
  }
}

// With flat tables the floor is the flat quality of no more quantisation noise than the estimate's
// standard tables (flat_quality_for_standard), the cap is mapped the same way, and the fit raises
// the quality within the input's bytes; the run report's standard quality is kept.
TEST(JpegTables, FlatPagesStartFromTheEstimatesEquivalent) {
  EXPECT_EQ(flat_quality_for_standard(90), 48);
  EXPECT_EQ(flat_quality_for_standard(95), 74);
  EXPECT_EQ(flat_quality_for_standard(100), 97);
  for (int q = 2; q <= 100; ++q) EXPECT_GE(flat_quality_for_standard(q), flat_quality_for_standard(q - 1)) << q;
  const Image page = photo_like(64, 64, 3);
  const JpegCoding flat{JpegTables::Flat, true};
  LoadedModel m;
  m.mesh.pages.resize(1);
  m.mesh.faces.resize(1);
  m.mesh.faces[0].page = 0;
  const size_t budget = encode_jpeg(page, 90, JpegSubsampling::S444).size();
  m.page_encodings = {{"jpeg", 90, budget, JpegSubsampling::S420}};
  PageWriteOptions po = choose_page_options(m, "input", 60, true, "4:4:4", flat);
  EXPECT_EQ(po.jpeg_standard_quality, 90);
  EXPECT_EQ(po.jpeg_quality, 48);
  EXPECT_EQ(po.jpeg_coding.tables, JpegTables::Flat);
  const JpegQualityFit fit = fit_page_quality(m, {page}, po, 100);
  EXPECT_TRUE(fit.within_budget);
  EXPECT_GT(po.jpeg_quality, 48);
  EXPECT_LE(po.jpeg_quality, 97);
  EXPECT_LE(fit.bytes, budget);
  EXPECT_EQ(fit.bytes, encode_jpeg(page, po.jpeg_quality, JpegSubsampling::S444, "p", flat).size());
  po = choose_page_options(m, "input", 60, true, "4:4:4", flat);
  fit_page_quality(m, {page}, po, 95);  // the cap maps too: 95 -> 74
  EXPECT_LE(po.jpeg_quality, 74);
  po = choose_page_options(m, "jpeg", 95, false, "4:4:4", flat);  // an explicit quality maps too
  EXPECT_EQ(po.jpeg_quality, 74);
  EXPECT_EQ(po.jpeg_standard_quality, 95);
}
