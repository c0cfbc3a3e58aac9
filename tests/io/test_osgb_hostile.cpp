// Hostile OSGB files (issue 11: "bad input gets a clear error naming the file; never a crash, hang
// or silent fix"): each is a tiny valid file built here with the osg API, then one field changed.
// On each, osgDB's own reader allocated gigabytes for a minute, crashed, or blocked for ever in
// this process (what fuzz_osgb found); read through the bounded reader (osgb_bounded.cpp, docs/io.md
// "OSGB: bounded reading") each is an error naming the file and the limit, within seconds, and the
// process that read it stays within the memory limit.
#include "texdefrag/io/osgb.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/production/production.h"
#include "texdefrag/util/paths.h"
#include "texdefrag/testing/fixtures.h"

#include <osg/Geode>
#include <osg/Geometry>
#include <osg/PagedLOD>
#include <osg/ProxyNode>
#include <osg/Texture2D>
#include <osgDB/Options>
#include <osgDB/WriteFile>

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TEXDEFRAG_TEST_ASAN 1
#endif
#endif

using namespace texdefrag;

namespace {

constexpr const char* kName = "hostile_marker_name";
constexpr float kMarker[3] = {1234.5f, -678.25f, 91.125f};  // the first vertex

// The address-space limit refuses the allocation: std::bad_alloc in the child, or under ASan (whose
// operator new reports out-of-memory and stops instead of throwing) the sanitizer's stop, which the
// child announces.
#ifdef TEXDEFRAG_TEST_ASAN
const std::string kOverMemory = "OpenSceneGraph's reader was stopped by the sanitizer runtime reading this file (its report is above; under the limit of ";
#else
const std::string kOverMemory = "OpenSceneGraph's reader exceeded ";
#endif

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const FormatError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void put(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

/// A Geode named kName with one triangle strip of 5 vertices (the first is kMarker), untextured.
osg::ref_ptr<osg::Geode> small_geode() {
  osg::ref_ptr<osg::Geometry> g = new osg::Geometry;
  osg::ref_ptr<osg::Vec3Array> v = new osg::Vec3Array;
  v->push_back(osg::Vec3(kMarker[0], kMarker[1], kMarker[2]));
  for (int i = 1; i < 5; ++i) v->push_back(osg::Vec3(static_cast<float>(i / 2), static_cast<float>(i % 2), 0.f));
  g->setVertexArray(v.get());
  g->addPrimitiveSet(new osg::DrawArrays(GL_TRIANGLE_STRIP, 0, 5));
  osg::ref_ptr<osg::Geode> geode = new osg::Geode;
  geode->setName(kName);
  geode->addDrawable(g.get());
  return geode;
}

std::string written(const osg::Node& node, const std::string& path) {
  EXPECT_TRUE(osgDB::writeNodeFile(node, path));
  return slurp(path);
}

/// The 32-bit little-endian value at offset `at`.
uint32_t int_at(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

/// Offset of the 32-bit little-endian `value` nearest before `at` (within 16 bytes).
size_t int_before(const std::string& bytes, size_t at, uint32_t value) {
  for (size_t p = at >= 4 ? at - 4 : 0; p + 16 >= at && p < bytes.size(); --p) {
    if (int_at(bytes, p) == value) return p;
    if (p == 0) break;
  }
  ADD_FAILURE() << "no " << value << " before offset " << at;
  return 0;
}

void set_int(std::string& bytes, size_t at, uint32_t value) { std::memcpy(&bytes[at], &value, 4); }

/// The largest resident size of a waited-for child process so far (bytes).
uint64_t children_max_rss() {
  rusage u{};
  getrusage(RUSAGE_CHILDREN, &u);
  return static_cast<uint64_t>(u.ru_maxrss) * 1024;
}

/// Reads `path` (OsgbFormat::read), returns the error, and checks that it took under `max_s`
/// seconds and that no reading process went past the memory limit.
std::string hostile_read(const std::string& path, double max_s) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string e = error_of([&] { OsgbFormat().read(path); });
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(s, max_s) << path;
  EXPECT_LT(children_max_rss(), osgb_read_limits(0).memory_bytes) << path;
  EXPECT_EQ(e.rfind(path + ": ", 0), 0u) << e;
  return e;
}

/// small_geode()'s triangle strip textured by a 4 x 4 RGB image named kImage (pixel bytes i * 5),
/// written with the image's pixels inline (osgDB's IncludeData).
constexpr const char* kImage = "hostile_image.png";
std::string written_textured(const std::string& path) {
  osg::ref_ptr<osg::Geode> geode = small_geode();
  osg::Geometry* g = geode->getDrawable(0)->asGeometry();
  osg::ref_ptr<osg::Vec2Array> tc = new osg::Vec2Array;
  for (int i = 0; i < 5; ++i) tc->push_back(osg::Vec2(0.1f * static_cast<float>(i + 1), 0.5f));
  g->setTexCoordArray(0, tc.get(), osg::Array::BIND_PER_VERTEX);
  osg::ref_ptr<osg::Image> im = new osg::Image;
  im->allocateImage(4, 4, 1, GL_RGB, GL_UNSIGNED_BYTE);
  for (int i = 0; i < 48; ++i) im->data()[i] = static_cast<unsigned char>(i * 5);
  im->setFileName(kImage);
  g->getOrCreateStateSet()->setTextureAttributeAndModes(0, new osg::Texture2D(im.get()), osg::StateAttribute::ON);
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeData");
  EXPECT_TRUE(osgDB::writeNodeFile(*geode, path, opt.get()));
  return slurp(path);
}

/// Offset of the inline image's field `k` after its file name: osgDB writes the write hint, the
/// decision, origin, s, t, r, internal format, pixel format, data type, packing, allocation mode,
/// byte count (k = 0 .. 11), 32 bits each.
size_t image_field(const std::string& bytes, int k) {
  const size_t name = bytes.find(kImage);
  EXPECT_NE(name, std::string::npos);
  return name + std::strlen(kImage) + 4 * static_cast<size_t>(k);
}

}  // namespace

TEST(OsgbHostile, TheUnchangedFileReads) {
  const std::string dir = texdefrag::testing::temp_dir();
  written(*small_geode(), dir + "/ok.osgb");
  const LoadedModel m = OsgbFormat().read(dir + "/ok.osgb");
  ASSERT_EQ(m.mesh.positions.size(), 5u);
  EXPECT_EQ(m.mesh.positions[0].x(), static_cast<double>(kMarker[0]));
  EXPECT_EQ(m.mesh.faces.size(), 3u);
}

// A name whose length field says 2 GiB: osgDB allocated and zero-filled a 2 GiB string before
// reading it (seconds and 2 GiB of memory per file; a file of such strings, minutes).
TEST(OsgbHostile, AStringLengthOfGigabytesExceedsTheMemoryLimit) {
  const std::string dir = texdefrag::testing::temp_dir();
  std::string bytes = written(*small_geode(), dir + "/ok.osgb");
  const size_t name = bytes.find(kName);
  ASSERT_NE(name, std::string::npos);
  set_int(bytes, int_before(bytes, name, static_cast<uint32_t>(std::strlen(kName))), 0x7ffffff0u);
  put(dir + "/long_name.osgb", bytes);
  const std::string e = hostile_read(dir + "/long_name.osgb", 30);
  const std::string limit = std::to_string((osgb_read_limits(bytes.size()).memory_bytes + (1u << 20) - 1) >> 20) + " MiB";
  EXPECT_NE(e.find(kOverMemory + limit), std::string::npos) << e;
  EXPECT_NE(e.find("the file is malformed"), std::string::npos) << e;
}

// A vertex array whose element count says 2^28 (3 GiB of Vec3): osgDB resized the array first.
TEST(OsgbHostile, AnArraySizeOfGigabytesExceedsTheMemoryLimit) {
  const std::string dir = texdefrag::testing::temp_dir();
  std::string bytes = written(*small_geode(), dir + "/ok.osgb");
  const size_t data = bytes.find(std::string(reinterpret_cast<const char*>(kMarker), sizeof kMarker));
  ASSERT_NE(data, std::string::npos);
  set_int(bytes, int_before(bytes, data, 5), 0x10000000u);
  put(dir + "/big_array.osgb", bytes);
  const std::string e = hostile_read(dir + "/big_array.osgb", 30);
  EXPECT_NE(e.find(kOverMemory), std::string::npos) << e;
}

// A ProxyNode (loaded while the file is read) naming a FIFO no one writes: osgDB blocked for ever
// opening it. The wall-time limit stops the reader (limits lowered so the test takes seconds).
TEST(OsgbHostile, AReadThatBlocksIsStoppedByTheWallTimeLimit) {
  const std::string dir = texdefrag::testing::temp_dir();
  ASSERT_EQ(::mkfifo((dir + "/blocked.osgb").c_str(), 0600), 0);
  osg::ref_ptr<osg::ProxyNode> proxy = new osg::ProxyNode;
  proxy->setLoadingExternalReferenceMode(osg::ProxyNode::LOAD_IMMEDIATELY);
  proxy->setFileName(0, "blocked.osgb");
  osg::ref_ptr<osg::Group> root = new osg::Group;
  root->addChild(small_geode().get());
  root->addChild(proxy.get());
  written(*root, dir + "/proxy.osgb");
  OsgbReadLimits l = osgb_read_limits(1000);
  l.wall_seconds = 2;
  set_osgb_read_limits(l);
  const std::string e = hostile_read(dir + "/proxy.osgb", 20);
  set_osgb_read_limits(std::nullopt);
  EXPECT_NE(e.find("OpenSceneGraph's reader did not finish within 2 s (wall time) reading this file"), std::string::npos)
      << e;
}

// A primitive set whose class name is not one osgDB knows: osgDB added a null primitive set to
// the geometry and dereferenced it (SIGSEGV, found by fuzz_osgb). The crash ends only the child.
TEST(OsgbHostile, ACrashOfTheReaderIsAnErrorNamingTheFile) {
  const std::string dir = texdefrag::testing::temp_dir();
  std::string bytes = written(*small_geode(), dir + "/ok.osgb");
  const size_t cls = bytes.find("osg::DrawArrays");
  ASSERT_NE(cls, std::string::npos);
  bytes[cls + std::strlen("osg::DrawArrays") - 1] = 'X';
  put(dir + "/null_set.osgb", bytes);
  const std::string e = hostile_read(dir + "/null_set.osgb", 30);
  EXPECT_NE(e.find("OpenSceneGraph's reader crashed reading this file (signal 11"), std::string::npos) << e;
}

// In a pyramid, the failing tile's error also names its parent (the file whose PagedLOD names it),
// found in the parent's bytes: the tile itself cannot be read.
TEST(OsgbHostile, AFailingTileOfAPyramidNamesItsParent) {
  const std::string root = texdefrag::testing::temp_dir() + "/prod";
  const std::string tile = root + "/Tile_A";
  std::filesystem::create_directories(tile);
  std::ofstream(root + "/metadata.xml") << "<ModelMetadata version=\"1\"><SRS>EPSG:4547</SRS></ModelMetadata>\n";
  osg::ref_ptr<osg::PagedLOD> lod = new osg::PagedLOD;
  lod->addChild(small_geode().get(), 0, 100);
  lod->setFileName(1, "Tile_A_L17_0.osgb");
  lod->setRange(1, 100, 1e30f);
  written(*lod, tile + "/Tile_A.osgb");
  std::string bytes = written(*small_geode(), tile + "/Tile_A_L17_0.osgb");
  bytes[bytes.find("osg::DrawArrays") + std::strlen("osg::DrawArrays") - 1] = 'X';
  put(tile + "/Tile_A_L17_0.osgb", bytes);
  EXPECT_EQ(osgb_parents(tile + "/Tile_A_L17_0.osgb"), std::vector<std::string>{tile + "/Tile_A.osgb"});
  EXPECT_TRUE(osgb_parents(tile + "/Tile_A.osgb").empty());

  const PipelineConfig cfg = load_config((std::filesystem::path(source_dir()) / "configs" / "repack.json").string());
  ProductionRunOptions ro;
  ro.output_dir = root + "_out";
  const json summary = run_production(cfg, list_production(root, ro.output_dir), ro);
  ASSERT_EQ(summary["tasks"].size(), 2u);
  EXPECT_EQ(summary["failed"], 1);
  const std::string e = summary["tasks"][1].value("error", "");
  EXPECT_NE(e.find("(Tile_A/Tile_A_L17_0.osgb): " + tile + "/Tile_A_L17_0.osgb: OpenSceneGraph's reader crashed"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find(" (a child of " + tile + "/Tile_A.osgb)"), std::string::npos) << e;
}

// An inline image's width, height, row packing and byte count are separate fields of the file;
// osgDB took them as they came, so a file declaring more pixels than its bytes (or a row packing
// of millions of bytes, what fuzz_osgb found) made the reader copy rows from past the buffer
// (ASan: SEGV in to_image). Each is now an error naming the file and the image.
TEST(OsgbHostile, AnImageDeclaringMorePixelsThanItsBytesIsRefused) {
  const std::string dir = texdefrag::testing::temp_dir();
  std::string bytes = written_textured(dir + "/ok.osgb");
  ASSERT_EQ(int_at(bytes, image_field(bytes, 3)), 4u);   // s
  ASSERT_EQ(int_at(bytes, image_field(bytes, 4)), 4u);   // t
  ASSERT_EQ(int_at(bytes, image_field(bytes, 9)), 1u);   // packing
  ASSERT_EQ(int_at(bytes, image_field(bytes, 11)), 48u); // bytes
  const LoadedModel ok = OsgbFormat().read(dir + "/ok.osgb");
  ASSERT_EQ(ok.page_images.size(), 1u);
  ASSERT_EQ(ok.page_images[0].pixels.size(), 48u);
  EXPECT_EQ(ok.page_images[0].pixels[0], 36 * 5);  // top row first: memory row 3 starts at byte 36
  std::string packed = bytes;
  set_int(packed, image_field(packed, 9), 0x003d0001u);
  put(dir + "/packing.osgb", packed);
  std::string e = error_of([&] { OsgbFormat().read(dir + "/packing.osgb"); });
  EXPECT_EQ(e, dir + "/packing.osgb: texture image '" + kImage + "' has row packing 3997697 (expected 1, 2, 4 or 8)");
  std::string wide = bytes;
  set_int(wide, image_field(wide, 3), 40u);
  put(dir + "/wide.osgb", wide);
  e = error_of([&] { OsgbFormat().read(dir + "/wide.osgb"); });
  const std::string expected = dir + "/wide.osgb: texture image '" + kImage +
                               "' declares 40 x 4 pixels of 3 bytes (packing 1: 480 bytes) but holds ";
  EXPECT_EQ(e.rfind(expected, 0), 0u) << e;
  EXPECT_NE(e.find("bytes: the file is malformed"), std::string::npos) << e;
  std::string empty = bytes;
  set_int(empty, image_field(empty, 4), 0u);
  put(dir + "/empty.osgb", empty);
  e = error_of([&] { OsgbFormat().read(dir + "/empty.osgb"); });
  EXPECT_EQ(e, dir + "/empty.osgb: texture image '" + kImage + "' is 4 x 0 pixels (expected 1 to 65536 a side)");
}
