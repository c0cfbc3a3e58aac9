// OSGB in and out on tiny scene graphs built here with the osg API: triangles, strips, fans,
// double vertices, a PagedLOD with an inline and a file child, two textures (one shared by two
// geometries). The round trip with configs/repack.json keeps every face and position bit-identical
// and the node structure identical; bad inputs are errors naming the file.
#include "osgb_test_util.h"
#include "stretch_test_util.h"
#include "texdefrag/io/osgb.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/production/production.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <osg/Geode>
#include <osg/Geometry>
#include <osg/MatrixTransform>
#include <osg/PagedLOD>
#include <osg/Texture2D>
#include <osg/NodeVisitor>
#include <osgDB/ReadFile>
#include <osgDB/WriteFile>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

/// A 32x32 RGB texture whose texels encode their position (x*8, y*8) and the page.
osg::ref_ptr<osg::Texture2D> make_texture(const std::string& name, int page) {
  osg::ref_ptr<osg::Image> im = new osg::Image;
  im->allocateImage(32, 32, 1, GL_RGB, GL_UNSIGNED_BYTE);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      unsigned char* p = im->data(x, y);
      p[0] = static_cast<unsigned char>(x * 8);
      p[1] = static_cast<unsigned char>(y * 8);
      p[2] = static_cast<unsigned char>(page * 100);
    }
  im->setFileName(name);
  osg::ref_ptr<osg::Texture2D> t = new osg::Texture2D(im.get());
  t->setWrap(osg::Texture::WRAP_S, osg::Texture::CLAMP_TO_EDGE);
  return t;
}

osg::ref_ptr<osg::StateSet> textured(osg::Texture2D* t) {
  osg::ref_ptr<osg::StateSet> ss = new osg::StateSet;
  ss->setTextureAttributeAndModes(0, t, osg::StateAttribute::ON);
  return ss;
}

/// A row of n vertices on two lines (x = i/2, y = i%2), UVs in [u0, u0+0.35] x [v0, v0+0.35].
template <class VecArray>
osg::ref_ptr<osg::Geometry> strip_geometry(int n, double u0, double v0, double z) {
  osg::ref_ptr<osg::Geometry> g = new osg::Geometry;
  osg::ref_ptr<VecArray> v = new VecArray;
  osg::ref_ptr<osg::Vec2Array> tc = new osg::Vec2Array;
  for (int i = 0; i < n; ++i) {
    v->push_back(typename VecArray::ElementDataType(0.1 + i / 2, 0.3 * (i % 2) + 0.7, z + 0.01 * i));
    tc->push_back(osg::Vec2(static_cast<float>(u0 + 0.35 * (i / 2) / (n / 2)), static_cast<float>(v0 + 0.35 * (i % 2))));
  }
  g->setVertexArray(v.get());
  g->setTexCoordArray(0, tc.get(), osg::Array::BIND_PER_VERTEX);
  return g;
}

struct Scene {
  std::string dir, tile, child;
};

/// tile.osgb: PagedLOD (inline Geode child + file child child.osgb) holding triangles (float),
/// a strip (double), a fan (float, sharing texture A) under a MatrixTransform, and a
/// DrawArrayLengths strip pair; child.osgb: one textured triangle list.
Scene build_scene(const std::string& dir, bool with_child = true, bool with_lines = false) {
  Scene s{dir, dir + "/tile.osgb", dir + "/child.osgb"};
  osg::ref_ptr<osg::Texture2D> ta = make_texture("a.png", 0), tb = make_texture("b.png", 1);

  osg::ref_ptr<osg::Geometry> tris = strip_geometry<osg::Vec3Array>(6, 0.05, 0.05, 0);
  osg::ref_ptr<osg::DrawElementsUShort> de = new osg::DrawElementsUShort(GL_TRIANGLES);
  for (unsigned short i : {0, 2, 1, 1, 2, 3, 2, 4, 3, 3, 4, 5}) de->push_back(i);
  tris->addPrimitiveSet(de.get());
  if (with_lines) tris->addPrimitiveSet(new osg::DrawArrays(GL_LINES, 0, 2));
  tris->setStateSet(textured(ta.get()).get());

  osg::ref_ptr<osg::Geometry> strip = strip_geometry<osg::Vec3dArray>(8, 0.5, 0.05, 5);
  strip->addPrimitiveSet(new osg::DrawArrays(GL_TRIANGLE_STRIP, 0, 8));
  strip->setStateSet(textured(tb.get()).get());

  osg::ref_ptr<osg::Geometry> fan = strip_geometry<osg::Vec3Array>(6, 0.05, 0.55, 10);
  osg::ref_ptr<osg::DrawElementsUInt> fe = new osg::DrawElementsUInt(GL_TRIANGLE_FAN);
  for (unsigned i : {0u, 1u, 3u, 5u, 4u, 2u}) fe->push_back(i);
  fan->addPrimitiveSet(fe.get());
  fan->setStateSet(textured(ta.get()).get());

  osg::ref_ptr<osg::Geometry> lengths = strip_geometry<osg::Vec3Array>(8, 0.5, 0.55, 15);
  osg::ref_ptr<osg::DrawArrayLengths> dal = new osg::DrawArrayLengths(GL_TRIANGLE_STRIP, 0);
  dal->push_back(4);
  dal->push_back(4);
  lengths->addPrimitiveSet(dal.get());
  lengths->setStateSet(textured(tb.get()).get());

  osg::ref_ptr<osg::Geode> geode = new osg::Geode;
  geode->addDrawable(tris.get());
  geode->addDrawable(strip.get());
  geode->addDrawable(lengths.get());
  osg::ref_ptr<osg::Geode> fan_geode = new osg::Geode;
  fan_geode->addDrawable(fan.get());
  osg::ref_ptr<osg::MatrixTransform> xf = new osg::MatrixTransform(osg::Matrix::translate(100.5, -3.25, 7));
  xf->addChild(fan_geode.get());
  osg::ref_ptr<osg::Group> inline_child = new osg::Group;
  inline_child->addChild(geode.get());
  inline_child->addChild(xf.get());

  osg::ref_ptr<osg::PagedLOD> lod = new osg::PagedLOD;
  lod->setCenterMode(osg::LOD::USER_DEFINED_CENTER);
  lod->setCenter(osg::Vec3(1.5f, 2.25f, 3.125f));
  lod->setRadius(42.5f);
  lod->setRangeMode(osg::LOD::PIXEL_SIZE_ON_SCREEN);
  lod->addChild(inline_child.get(), 0, 38.25f);
  lod->setFileName(1, "child.osgb");
  lod->setRange(1, 38.25f, 1e30f);
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeData");
  EXPECT_TRUE(osgDB::writeNodeFile(*lod, s.tile, opt.get()));

  if (with_child) {
    osg::ref_ptr<osg::Geometry> c = strip_geometry<osg::Vec3Array>(6, 0.1, 0.1, 20);
    osg::ref_ptr<osg::DrawElementsUShort> ce = new osg::DrawElementsUShort(GL_TRIANGLES);
    for (unsigned short i : {0, 2, 1, 1, 2, 3, 2, 4, 3, 3, 4, 5}) ce->push_back(i);
    c->addPrimitiveSet(ce.get());
    c->setStateSet(textured(make_texture("c.png", 2).get()).get());
    osg::ref_ptr<osg::Geode> cg = new osg::Geode;
    cg->addDrawable(c.get());
    EXPECT_TRUE(osgDB::writeNodeFile(*cg, s.child, opt.get()));
  }
  return s;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

json run(const std::string& input, const std::string& out, const std::string& config = "repack.json") {
  const PipelineConfig cfg = load_config((fs::path(source_dir()) / "configs" / config).string());
  RunOptions ro;
  ro.input = input;
  ro.output_dir = out;
  return run_pipeline(cfg, ro);
}

/// Colour of the texel under the centroid of face f's UV triangle.
std::array<int, 3> centroid_colour(const LoadedModel& m, size_t f) {
  const Face& F = m.mesh.faces[f];
  Vec2 c(0, 0);
  for (int k = 0; k < 3; ++k) c += m.mesh.texcoords[static_cast<size_t>(F.vt[static_cast<size_t>(k)])] / 3.0;
  const Image& img = m.page_images[static_cast<size_t>(F.page)];
  const int x = std::clamp(static_cast<int>(c.x() * img.width), 0, img.width - 1);
  const int y = std::clamp(img.height - 1 - static_cast<int>(c.y() * img.height), 0, img.height - 1);
  const uint8_t* p = img.at(x, y);
  return {p[0], p[1], p[2]};
}

}  // namespace

TEST(Osgb, ReadsEveryPrimitiveKind) {
  const Scene s = build_scene(texdefrag::testing::temp_dir());
  ASSERT_EQ(format_for_input(s.tile).name(), "osgb");
  const LoadedModel m = OsgbFormat().read(s.tile);
  // triangles 4, strip of 8 -> 6, fan of 6 -> 4, two strips of 4 -> 2 + 2
  EXPECT_EQ(m.mesh.faces.size(), 4u + 6u + 4u + 4u);
  EXPECT_EQ(m.mesh.pages.size(), 2u);  // a.png (shared by two geometries) and b.png
  EXPECT_EQ(m.page_images.size(), 2u);
  EXPECT_TRUE(m.missing_files.empty());
  // Strip winding as OpenGL draws it: triangle 1 of the strip is (2, 1, 3).
  const Face& odd = m.mesh.faces[5];
  EXPECT_EQ(odd.v[0] - m.mesh.faces[4].v[0], 2);
  EXPECT_EQ(odd.v[1] - m.mesh.faces[4].v[0], 1);
  EXPECT_EQ(odd.v[2] - m.mesh.faces[4].v[0], 3);
  // Double positions are kept exactly (0.1 + 0 is not a float).
  EXPECT_EQ(m.mesh.positions[static_cast<size_t>(m.mesh.faces[4].v[0])].x(), 0.1);
  EXPECT_EQ(osgb_children(s.tile), std::vector<std::string>{s.child});
}

TEST(Osgb, RoundTripKeepsFacesPositionsAndStructure) {
  const Scene s = build_scene(texdefrag::testing::temp_dir());
  const std::string out = s.dir + "/out";
  const json report = run(s.tile, out);
  const std::string written = out + "/tile.osgb";
  ASSERT_TRUE(fs::exists(written));
  EXPECT_EQ(report["stages"]["write"]["format"], "osgb");
  EXPECT_EQ(report["stages"]["write"]["geometries_split"], 0);
  EXPECT_EQ(report["stages"]["write"]["faces_turned_as_written"], 0);
  const LoadedModel in = OsgbFormat().read(s.tile);
  const LoadedModel back = OsgbFormat().read(written);
  osgb_test::expect_same_positions(in.mesh, back.mesh, written);
  EXPECT_EQ(osgb_test::structure(s.tile), osgb_test::structure(written));
  ASSERT_EQ(back.mesh.pages.size(), 1u);  // both 32x32 pages packed onto one
  EXPECT_EQ(back.page_encodings[0].format, "png");
  // Texels are copied exactly (repack moves charts by whole texels).
  for (size_t f = 0; f < in.mesh.faces.size(); ++f) EXPECT_EQ(centroid_colour(in, f), centroid_colour(back, f)) << f;
  // The child file name is kept relative, not turned into the input's folder.
  std::ifstream raw(written, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(raw)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes.find(s.dir), std::string::npos) << "the output names the input folder";
  EXPECT_NE(bytes.find("child.osgb"), std::string::npos);
}

TEST(Osgb, WrittenFilesReadBackInOsgconv) {
  if (std::system("command -v osgconv > /dev/null 2>&1") != 0) GTEST_SKIP() << "osgconv not installed (Debian package openscenegraph)";
  const Scene s = build_scene(texdefrag::testing::temp_dir());
  const std::string out = s.dir + "/out";
  run(s.tile, out, "best.json");
  const std::string cmd = "osgconv '" + out + "/tile.osgb' '" + s.dir + "/check.osgt' > '" + s.dir + "/osgconv.log' 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  EXPECT_TRUE(fs::exists(s.dir + "/check.osgt"));
}

TEST(Osgb, MissingChildIsAnErrorNamingFileAndParent) {
  const Scene s = build_scene(texdefrag::testing::temp_dir(), false);
  const std::string e = error_of([&] { run(s.tile, s.dir + "/out"); });
  EXPECT_NE(e.find(s.child), std::string::npos) << e;
  EXPECT_NE(e.find("of " + s.tile), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(s.dir + "/out/tile.osgb"));
  const LoadedModel m = OsgbFormat().read(s.tile);
  EXPECT_EQ(m.missing_files.size(), 1u);
}

TEST(Osgb, LinesInATexturedGeometryAreAnError) {
  const Scene s = build_scene(texdefrag::testing::temp_dir(), true, true);
  const std::string e = error_of([&] { OsgbFormat().read(s.tile); });
  EXPECT_NE(e.find(s.tile + ": primitive set 1 (DrawArrays) of a textured geometry: unsupported"), std::string::npos) << e;
}

TEST(Osgb, TruncatedFileIsAnErrorNamingIt) {
  const Scene s = build_scene(texdefrag::testing::temp_dir());
  const std::string cut = s.dir + "/cut.osgb";
  {
    std::ifstream in(s.tile, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const std::string e = error_of([&] { OsgbFormat().read(cut); });
  EXPECT_EQ(e.rfind(cut + ": ", 0), 0u) << e;
}

// A production folder built from the scenes above: metadata.xml, Tile_A/ with a root PagedLOD
// file and its child, Tile_B/ with an untextured root (copied unchanged).
TEST(Production, RunsEveryTileIntoTheSameLayout) {
  const std::string root = texdefrag::testing::temp_dir() + "/prod";
  fs::create_directories(root + "/Tile_A");
  build_scene(root + "/Tile_A");
  fs::rename(root + "/Tile_A/tile.osgb", root + "/Tile_A/Tile_A.osgb");
  std::ofstream(root + "/metadata.xml") << "<ModelMetadata version=\"1\"><SRS>EPSG:4547</SRS></ModelMetadata>\n";
  fs::create_directories(root + "/Tile_B");
  {
    osg::ref_ptr<osg::Geode> g = new osg::Geode;
    osg::ref_ptr<osg::Geometry> geo = strip_geometry<osg::Vec3Array>(4, 0, 0, 0);
    geo->setTexCoordArray(0, nullptr);
    geo->addPrimitiveSet(new osg::DrawArrays(GL_TRIANGLE_STRIP, 0, 4));
    g->addDrawable(geo.get());
    ASSERT_TRUE(osgDB::writeNodeFile(*g, root + "/Tile_B/Tile_B.osgb"));
  }
  const std::string out = root + "_out";
  const Production p = list_production(root, out);
  EXPECT_EQ(p.kind, "contextcapture");
  ASSERT_EQ(p.tasks.size(), 3u);
  EXPECT_EQ(p.tasks[0].relative, "Tile_A/Tile_A.osgb");
  EXPECT_EQ(p.tasks[0].level, "root");
  EXPECT_EQ(p.tasks[1].relative, "Tile_A/child.osgb");
  EXPECT_EQ(p.tasks[0].output_dir, out + "/Tile_A");
  EXPECT_EQ(p.copies, std::vector<std::string>{"metadata.xml"});
  EXPECT_EQ(production_json(p)["tasks"].size(), 3u);

  const PipelineConfig cfg = load_config((fs::path(source_dir()) / "configs" / "repack.json").string());
  ProductionRunOptions ro;
  ro.output_dir = out;
  const json summary = run_production(cfg, p, ro);
  for (const char* f : {"metadata.xml", "Tile_A/Tile_A.osgb", "Tile_A/child.osgb", "Tile_B/Tile_B.osgb",
                        "Tile_A/Tile_A.report.json", "texdefrag_summary.json"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  EXPECT_EQ(bytes(root + "/metadata.xml"), bytes(out + "/metadata.xml"));
  EXPECT_EQ(bytes(root + "/Tile_B/Tile_B.osgb"), bytes(out + "/Tile_B/Tile_B.osgb"));  // no texture: copied
  EXPECT_EQ(summary["tasks"].size(), 3u);
  EXPECT_TRUE(summary["tasks"][2]["copied"].get<bool>());
  EXPECT_EQ(summary["levels"]["all"]["tasks"], 3);
  const LoadedModel in = OsgbFormat().read(root + "/Tile_A/Tile_A.osgb");
  const LoadedModel back = OsgbFormat().read(out + "/Tile_A/Tile_A.osgb");
  osgb_test::expect_same_positions(in.mesh, back.mesh, "Tile_A");
  EXPECT_EQ(osgb_test::structure(root + "/Tile_A/Tile_A.osgb"), osgb_test::structure(out + "/Tile_A/Tile_A.osgb"));

  EXPECT_EQ(summary["failed"], 0);
  for (const json& row : summary["tasks"]) EXPECT_EQ(row["status"], "ok") << row.dump();

  // Output inside the production, a folder with only a tileset.json: errors.
  ro.output_dir = root + "/out";
  EXPECT_NE(error_of([&] { run_production(cfg, list_production(root, ro.output_dir), ro); }).find("inside it"),
            std::string::npos);
  const std::string tiles = texdefrag::testing::temp_dir() + "/tiles";
  fs::create_directories(tiles);
  std::ofstream(tiles + "/tileset.json") << "{}";
  EXPECT_NE(error_of([&] { list_production(tiles, ""); }).find("3D Tiles"), std::string::npos);
}

// A failing tile (a missing PagedLOD child, an unreadable file) is recorded in the summary with its
// error naming the file; none of its files appear; the other tiles and the copies go on.
TEST(Production, AFailingTileIsRecordedAndTheOthersGoOn) {
  const std::string root = texdefrag::testing::temp_dir() + "/prod";
  for (const char* t : {"Tile_A", "Tile_B"}) {
    fs::create_directories(root + "/" + t);
    build_scene(root + "/" + t);
    fs::rename(root + "/" + t + "/tile.osgb", root + "/" + t + "/" + t + ".osgb");
  }
  fs::remove(root + "/Tile_A/child.osgb");  // Tile_A's root names it
  fs::create_directories(root + "/Tile_C");
  std::ofstream(root + "/Tile_C/Tile_C.osgb") << "not an osgb file";
  std::ofstream(root + "/metadata.xml") << "<ModelMetadata version=\"1\"><SRS>EPSG:4547</SRS></ModelMetadata>\n";
  const std::string out = root + "_out";
  const Production p = list_production(root, out);
  ASSERT_EQ(p.tasks.size(), 4u);  // Tile_A root, Tile_B root and child, Tile_C root
  const PipelineConfig cfg = load_config((fs::path(source_dir()) / "configs" / "repack.json").string());
  ProductionRunOptions ro;
  ro.output_dir = out;
  std::vector<std::string> seen;
  ro.on_task = [&](size_t, const ProductionTask& t, const json& row, const json& report) {
    seen.push_back(t.relative + ":" + row["status"].get<std::string>());
    EXPECT_EQ(report.is_null(), row["status"] == "failed") << t.relative;
  };
  const json summary = run_production(cfg, p, ro);
  EXPECT_EQ(seen, (std::vector<std::string>{"Tile_A/Tile_A.osgb:failed", "Tile_B/Tile_B.osgb:ok",
                                            "Tile_B/child.osgb:ok", "Tile_C/Tile_C.osgb:failed"}));
  EXPECT_EQ(summary["failed"], 2);
  EXPECT_EQ(summary["levels"]["all"]["tasks"], 4);
  EXPECT_EQ(summary["levels"]["all"]["failed"], 2);
  const json on_disk = json::parse(std::ifstream(out + "/texdefrag_summary.json"));
  EXPECT_EQ(on_disk["tasks"], summary["tasks"]);
  const std::string e0 = summary["tasks"][0].value("error", "");
  EXPECT_NE(e0.find("production task 1/4 (Tile_A/Tile_A.osgb)"), std::string::npos) << e0;
  EXPECT_NE(e0.find("child 'child.osgb' of " + root + "/Tile_A/Tile_A.osgb"), std::string::npos) << e0;
  const std::string e3 = summary["tasks"][3].value("error", "");
  EXPECT_NE(e3.find(root + "/Tile_C/Tile_C.osgb: "), std::string::npos) << e3;
  // Nothing of the failed tiles, everything of the good one, the copy; no staging left.
  EXPECT_FALSE(fs::exists(out + "/Tile_A/Tile_A.osgb"));
  EXPECT_FALSE(fs::exists(out + "/Tile_C/Tile_C.osgb"));
  EXPECT_FALSE(fs::exists(out + "/Tile_C/Tile_C.report.json"));
  for (const char* f : {"Tile_B/Tile_B.osgb", "Tile_B/child.osgb", "Tile_B/Tile_B.report.json", "metadata.xml"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  for (const auto& entry : fs::recursive_directory_iterator(out))
    EXPECT_EQ(entry.path().filename().string().find(".texdefrag-staging"), std::string::npos) << entry.path();
  // The inputs are untouched: still the garbage tile and no output in the production.
  EXPECT_FALSE(fs::exists(root + "/Tile_B/Tile_B.report.json"));
}

namespace {

/// A roof of 8 x 8 quads, each its own UV chart (4 vertices of its own, as photogrammetry writes
/// them): x in [0, 2] with the ridge at x = 1 (z = 0.3 * min(x, 2 - x)), y in [0, 4]. `sx` scales
/// the stored x coordinates. UV cells of 1/8 of the page, the chart 80% of its cell.
osg::ref_ptr<osg::Geometry> roof_geometry(float sx) {
  osg::ref_ptr<osg::Geometry> g = new osg::Geometry;
  osg::ref_ptr<osg::Vec3Array> v = new osg::Vec3Array;
  osg::ref_ptr<osg::Vec2Array> tc = new osg::Vec2Array;
  osg::ref_ptr<osg::DrawElementsUShort> tri = new osg::DrawElementsUShort(GL_TRIANGLES);
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      const auto base = static_cast<unsigned short>(v->size());
      for (int c = 0; c < 4; ++c) {
        const int di = c == 1 || c == 2, dj = c >= 2;
        const float x = 0.25f * static_cast<float>(i + di), y = 0.5f * static_cast<float>(j + dj);
        v->push_back(osg::Vec3(sx * x, y, 0.3f * std::min(x, 2.0f - x)));
        tc->push_back(osg::Vec2((static_cast<float>(i) + 0.1f + 0.8f * static_cast<float>(di)) / 8.0f,
                                (static_cast<float>(j) + 0.1f + 0.8f * static_cast<float>(dj)) / 8.0f));
      }
      for (int k : {0, 1, 2, 0, 2, 3}) tri->push_back(static_cast<unsigned short>(base + k));
    }
  g->setVertexArray(v.get());
  g->setTexCoordArray(0, tc.get(), osg::Array::BIND_PER_VERTEX);
  g->addPrimitiveSet(tri.get());
  g->setStateSet(textured(make_texture("roof.png", 1).get()).get());
  return g;
}

/// Writes the roof: its x scaled by `stored_sx` in the file, under a MatrixTransform `m` (none when
/// identity).
std::string write_roof(const std::string& path, float stored_sx, const osg::Matrix& m) {
  osg::ref_ptr<osg::Geode> geode = new osg::Geode;
  geode->addDrawable(roof_geometry(stored_sx).get());
  osg::ref_ptr<osg::Node> root = geode;
  if (!m.isIdentity()) {
    osg::ref_ptr<osg::MatrixTransform> xf = new osg::MatrixTransform(m);
    xf->addChild(geode.get());
    root = xf;
  }
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeData");
  EXPECT_TRUE(osgDB::writeNodeFile(*root, path, opt.get()));
  return path;
}

/// The stored vertex array of the first geometry of a file, as osgDB reads it.
std::vector<osg::Vec3> stored_positions(const std::string& path) {
  struct Find : osg::NodeVisitor {
    Find() : osg::NodeVisitor(TRAVERSE_ALL_CHILDREN) {}
    void apply(osg::Drawable& d) override {
      if (!geometry) geometry = d.asGeometry();
    }
    osg::Geometry* geometry = nullptr;
  } find;
  osg::ref_ptr<osg::Node> n = osgDB::readRefNodeFile(path);
  if (!n) return {};
  n->accept(find);
  const auto* v = find.geometry ? dynamic_cast<const osg::Vec3Array*>(find.geometry->getVertexArray()) : nullptr;
  return v ? std::vector<osg::Vec3>(v->begin(), v->end()) : std::vector<osg::Vec3>{};
}

}  // namespace

// A MatrixTransform scaling x by 2 above a mesh: texdefrag measures the mesh as the user sees it
// (io/measure_transform.h), so every stage gives what it gives on the same mesh stored pre-scaled,
// while the file written keeps the stored (unscaled) positions bit for bit. A rigid transform
// leaves the positions read as stored.
TEST(Osgb, NodeTransformsAreAppliedForMeasuringOnly) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string scaled = write_roof(dir + "/scaled.osgb", 1, osg::Matrix::scale(2, 1, 1));
  const std::string prescaled = write_roof(dir + "/prescaled.osgb", 2, osg::Matrix::identity());
  const std::string plain = write_roof(dir + "/plain.osgb", 1, osg::Matrix::identity());
  const std::string rigid = write_roof(dir + "/rigid.osgb", 1,
                                       osg::Matrix::rotate(0.7, osg::Vec3(0.3, 0.4, 0.5)) * osg::Matrix::translate(5e5, 4e6, 30));

  const LoadedModel a = OsgbFormat().read(scaled), b = OsgbFormat().read(prescaled);
  ASSERT_EQ(a.mesh.positions.size(), 256u);
  EXPECT_EQ(a.positions_stretched, 256u);
  for (size_t i = 0; i < a.mesh.positions.size(); ++i) EXPECT_EQ(a.mesh.positions[i], b.mesh.positions[i]) << i;
  const LoadedModel r = OsgbFormat().read(rigid), p = OsgbFormat().read(plain);
  EXPECT_EQ(r.positions_stretched, 0u);
  for (size_t i = 0; i < r.mesh.positions.size(); ++i) EXPECT_EQ(r.mesh.positions[i], p.mesh.positions[i]) << i;

  const json ra = run(scaled, dir + "/out_scaled", "best.json");
  const json rb = run(prescaled, dir + "/out_prescaled", "best.json");
  const json rp = run(plain, dir + "/out_plain", "best.json");
  texdefrag::testing::expect_stretch_measured(ra, rb, rp, 256);
  const LoadedModel oa = OsgbFormat().read(dir + "/out_scaled/scaled.osgb");
  const LoadedModel ob = OsgbFormat().read(dir + "/out_prescaled/prescaled.osgb");
  EXPECT_EQ(oa.mesh.texcoords, ob.mesh.texcoords);
  // Written: the stored, unscaled positions, bit for bit.
  const std::vector<osg::Vec3> in_stored = stored_positions(scaled), out_stored = stored_positions(dir + "/out_scaled/scaled.osgb");
  ASSERT_EQ(in_stored.size(), 256u);
  EXPECT_EQ(std::memcmp(in_stored.data(), out_stored.data(), in_stored.size() * sizeof(osg::Vec3)), 0);
  EXPECT_EQ(in_stored.size(), out_stored.size());
}
