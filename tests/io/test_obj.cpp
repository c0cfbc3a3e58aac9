// OBJ/MTL reader and writer on tiny hand-written files: one test per feature, every error message
// checked for FILE:LINE.
#include "io_test_util.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <cctype>
#include <charconv>
#include <cstring>
#include <functional>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

namespace fs = std::filesystem;
using namespace texdefrag;
namespace tt = texdefrag::testing;
using texdefrag::io_test::count_temporaries;
using texdefrag::io_test::obj_error;
using texdefrag::io_test::read_text;
using texdefrag::io_test::write_text;

namespace {

ObjReadOptions no_textures() {
  ObjReadOptions o;
  o.read_page_sizes = false;
  o.require_textures = false;
  return o;
}

/// Checks that an error message starts with "file:line: " and contains `what`.
void expect_error_at(const std::string& msg, const std::string& file, int line, const std::string& what) {
  const std::string prefix = file + ":" + std::to_string(line) + ": ";
  EXPECT_EQ(msg.compare(0, prefix.size(), prefix), 0) << "message: " << msg << "\nexpected prefix: " << prefix;
  EXPECT_NE(msg.find(what), std::string::npos) << "message: " << msg << "\nexpected to contain: " << what;
}

const char* kTwoPageMtl =
    "newmtl red\n"
    "Kd 1 0 0\n"
    "map_Kd red.png\n"
    "\n"
    "newmtl blue\n"
    "Kd 0 0 1\n"
    "map_Kd blue.png\n";

const char* kTwoPageObj =
    "mtllib two.mtl\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "vt 0 0\n"
    "vt 1 0\n"
    "vt 1 1\n"
    "vt 0 1\n"
    "usemtl red\n"
    "f 1/1 2/2 3/3\n"
    "usemtl blue\n"
    "f 1/1 3/3 4/4\n";

}  // namespace

TEST(ObjRead, TwoMaterialsTwoPagesWithSizesFromImageHeaders) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "two.mtl", kTwoPageMtl);
  tt::write_test_image(dir + "/red.png", 8, 4);
  tt::write_test_image(dir + "/blue.png", 16, 32);
  const std::string obj = write_text(dir, "two.obj", kTwoPageObj);

  const TexturedMesh m = read_obj(obj);
  ASSERT_EQ(m.positions.size(), 4u);
  ASSERT_EQ(m.texcoords.size(), 4u);
  ASSERT_EQ(m.faces.size(), 2u);
  ASSERT_EQ(m.materials.size(), 2u);
  ASSERT_EQ(m.pages.size(), 2u);
  EXPECT_EQ(m.materials[0].name, "red");
  EXPECT_EQ(m.materials[0].map_kd, "red.png");
  EXPECT_EQ(m.materials[0].extra_lines, std::vector<std::string>{"Kd 1 0 0"});
  EXPECT_EQ(m.pages[0].material, "red");
  EXPECT_EQ(m.pages[0].image_path, (fs::path(dir) / "red.png").string());
  EXPECT_EQ(m.pages[0].width, 8);
  EXPECT_EQ(m.pages[0].height, 4);
  EXPECT_EQ(m.pages[1].material, "blue");
  EXPECT_EQ(m.pages[1].width, 16);
  EXPECT_EQ(m.pages[1].height, 32);

  const Face& a = m.faces[0];
  EXPECT_EQ(a.v, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(a.vt, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(a.vn, (std::array<int, 3>{kNoIndex, kNoIndex, kNoIndex}));
  EXPECT_EQ(a.material, 0);
  EXPECT_EQ(a.page, 0);
  EXPECT_EQ(a.group, kNoIndex);
  EXPECT_EQ(a.source_line, 11);
  EXPECT_EQ(a.polygon_corner, 0);
  const Face& b = m.faces[1];
  EXPECT_EQ(b.v, (std::array<int, 3>{0, 2, 3}));
  EXPECT_EQ(b.material, 1);
  EXPECT_EQ(b.page, 1);
  EXPECT_EQ(b.source_line, 13);
  // corner_texel uses the page size: (1, 1) on the 16x32 page is (16, 32).
  EXPECT_EQ(m.corner_texel(1, 1), Vec2(16, 32));
}

TEST(ObjRead, SeveralMtllibsMapKdOptionsAndPathsWithSpacesRelativeToMtlFolder) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "mats/a.mtl",
             "# comment before the first material\n"
             "newmtl roof\n"
             "  Ka 1 1 1 1\n"
             "  Kd 0.5 0.5 0.5 1\n"
             "  map_Kd -bm 1 -s 1 1 1 roof tiles.png\n");
  write_text(dir, "mats/b.mtl",
             "newmtl wall\n"
             "map_Kd -o 0.5 -clamp on textures/wall 2.png\n"
             "newmtl plain\n"
             "Kd 0.2 0.2 0.2\n");
  write_text(dir, "c.mtl", "newmtl glass\nmap_Kd -s 2 glass.png\n");
  fs::create_directories(dir + "/mats/textures");
  tt::write_test_image(dir + "/mats/roof tiles.png", 4, 4);
  tt::write_test_image(dir + "/mats/textures/wall 2.png", 2, 6);
  tt::write_test_image(dir + "/glass.png", 3, 3);
  const std::string obj = write_text(dir, "m.obj",
                                     "mtllib mats/a.mtl mats/b.mtl\n"
                                     "mtllib c.mtl\n"
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                     "usemtl wall\nf 1/1 2/2 3/3\n"
                                     "usemtl glass\nf 1/1 2/2 3/3\n"
                                     "usemtl plain\nf 1/1 2/2 3/3\n"
                                     "usemtl roof\nf 1/1 2/2 3/3\n");
  const TexturedMesh m = read_obj(obj);
  ASSERT_EQ(m.materials.size(), 4u);
  ASSERT_EQ(m.pages.size(), 3u);  // "plain" has no map_Kd: not a page
  EXPECT_EQ(m.materials[0].name, "roof");
  EXPECT_EQ(m.materials[0].map_kd_options, "-bm 1 -s 1 1 1");
  EXPECT_EQ(m.materials[0].map_kd, "roof tiles.png");
  EXPECT_EQ(m.materials[0].extra_lines, (std::vector<std::string>{"  Ka 1 1 1 1", "  Kd 0.5 0.5 0.5 1"}));
  EXPECT_EQ(m.materials[1].map_kd_options, "-o 0.5 -clamp on");
  EXPECT_EQ(m.materials[1].map_kd, "textures/wall 2.png");
  EXPECT_EQ(m.materials[2].name, "plain");
  EXPECT_TRUE(m.materials[2].map_kd.empty());
  EXPECT_EQ(m.materials[3].map_kd_options, "-s 2");
  EXPECT_EQ(m.pages[0].image_path, (fs::path(dir) / "mats/roof tiles.png").string());
  EXPECT_EQ(m.pages[1].image_path, (fs::path(dir) / "mats/textures/wall 2.png").string());
  EXPECT_EQ(m.pages[2].image_path, (fs::path(dir) / "glass.png").string());
  EXPECT_EQ(m.pages[1].width, 2);
  EXPECT_EQ(m.pages[1].height, 6);
  // Addressing: `-clamp on` clamps, the MTL default repeats.
  EXPECT_FALSE(m.pages[0].clamp);
  EXPECT_TRUE(m.pages[1].clamp);
  EXPECT_FALSE(m.pages[2].clamp);
  // Every file read, for the write service to protect.
  EXPECT_EQ(m.source_files.front(), obj);
  EXPECT_EQ(m.source_files.size(), 1u + 3u + 3u) << "the OBJ, three MTLs, three page images";
  // Faces: wall -> page 1, glass -> page 2, plain -> textured face on a material without image
  // -> kNoPage, roof -> page 0.
  ASSERT_EQ(m.faces.size(), 4u);
  EXPECT_EQ(m.faces[0].material, 1);
  EXPECT_EQ(m.faces[0].page, 1);
  EXPECT_EQ(m.faces[1].material, 3);
  EXPECT_EQ(m.faces[1].page, 2);
  EXPECT_EQ(m.faces[2].material, 2);
  EXPECT_EQ(m.faces[2].page, kNoPage);
  EXPECT_EQ(m.faces[3].material, 0);
  EXPECT_EQ(m.faces[3].page, 0);
}

TEST(ObjRead, MtllibWhoseFileNameHasBlanks) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "my materials.mtl", "newmtl a\nKd 1 1 1\n");
  const std::string obj = write_text(dir, "m.obj", "mtllib my materials.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  const TexturedMesh m = read_obj(obj);
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.faces[0].material, 0);
  EXPECT_EQ(m.faces[0].page, kNoPage);
}

TEST(ObjRead, NegativeIndicesCountBackFromTheLatestElement) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "neg.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                     "f -3/-3 -2/-2 -1/-1\n"
                                     "v 5 5 5\nvt 0.5 0.5\n"
                                     "f -4/-4 -1/-1 -2/-2\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.faces.size(), 2u);
  EXPECT_EQ(m.faces[0].v, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.faces[0].vt, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.faces[1].v, (std::array<int, 3>{0, 3, 2}));
  EXPECT_EQ(m.faces[1].vt, (std::array<int, 3>{0, 3, 2}));
}

TEST(ObjRead, PolygonsAreFanTriangulatedWithSourceLineAndCorner) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "poly.obj",
                                     "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\n"
                                     "f 1 2 3 4 5\n"
                                     "f 1 2 3 4\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.faces.size(), 5u);
  const std::array<std::array<int, 3>, 5> tris = {{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 1, 2}, {0, 2, 3}}};
  const int corner[5] = {0, 1, 2, 0, 1};
  const int line[5] = {6, 6, 6, 7, 7};
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(m.faces[i].v, tris[i]) << i;
    EXPECT_EQ(m.faces[i].polygon_corner, corner[i]) << i;
    EXPECT_EQ(m.faces[i].source_line, line[i]) << i;
    EXPECT_EQ(m.faces[i].page, kNoPage) << i;
  }
}

TEST(ObjRead, VertexColoursAreKeptOnePerPosition) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "c.obj",
                                     "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0.25 0.5 0.125\nv 1 1 0 1\n"
                                     "f 1 2 3\n");
  // The 4th line is x y z w with w = 1: a plain position, so the file mixes -> error on line 4.
  EXPECT_NE(obj_error(obj, no_textures()).find("c.obj:4: no vertex colour"), std::string::npos);
  write_text(dir, "c.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0.25 0.5 0.125\nf 1 2 3\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.colors.size(), 3u);
  EXPECT_EQ(m.colors[1], Vec3(0, 1, 0));
  EXPECT_EQ(m.colors[2], Vec3(0.25, 0.5, 0.125));
  EXPECT_EQ(m.positions[2], Vec3(0, 1, 0));
  const TexturedMesh plain = read_obj(write_text(dir, "p.obj", "v 0 0 0\nv 1 0 0 1\nv 0 1 0\nf 1 2 3\n"), no_textures());
  EXPECT_TRUE(plain.colors.empty());
}

TEST(ObjRead, TexcoordWithThreeNumbersKeepsUV) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "vt3.obj", "vt 0.25 0.75 0\nvt 0.5 0.125\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.texcoords.size(), 2u);
  EXPECT_EQ(m.texcoords[0], Vec2(0.25, 0.75));
  EXPECT_EQ(m.texcoords[1], Vec2(0.5, 0.125));
}

TEST(ObjRead, TrailingSlashWithEmptyNormalAsContextCaptureWrites) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "cc.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                     "f 3/3/ 2/2/ 1/1/ \n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.faces.size(), 1u);
  EXPECT_EQ(m.faces[0].v, (std::array<int, 3>{2, 1, 0}));
  EXPECT_EQ(m.faces[0].vt, (std::array<int, 3>{2, 1, 0}));
  EXPECT_EQ(m.faces[0].vn, (std::array<int, 3>{kNoIndex, kNoIndex, kNoIndex}));
}

TEST(ObjRead, NormalsWithAndWithoutTexcoords) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "vn.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n"
                                     "f 1//1 2//1 3//2\n"
                                     "f 1/1/2 2/2/2 3/3/1\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.normals.size(), 2u);
  EXPECT_EQ(m.normals[1], Vec3(0, 0, -1));
  EXPECT_EQ(m.faces[0].vn, (std::array<int, 3>{0, 0, 1}));
  EXPECT_EQ(m.faces[0].vt, (std::array<int, 3>{kNoIndex, kNoIndex, kNoIndex}));
  EXPECT_EQ(m.faces[1].vt, (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.faces[1].vn, (std::array<int, 3>{1, 1, 0}));
}

TEST(ObjRead, CrlfCommentsBlankLinesTabsAndPlusSigns) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "m.mtl", "# header\r\n\r\nnewmtl a\r\n\tKa 1 1 1 1\r\nmap_Kd t.png\r\n");
  tt::write_test_image(dir + "/t.png", 5, 7);
  const std::string obj = write_text(dir, "crlf.obj",
                                     "# a comment\r\n"
                                     "\r\n"
                                     "mtllib m.mtl\r\n"
                                     "v\t0 0 0 # trailing comment\r\n"
                                     "v +1 0 0\r\n"
                                     "v 0 1e0 -0\r\n"
                                     "   \r\n"
                                     "vt 0 0\r\nvt 1 0\r\nvt 0 1\r\n"
                                     "usemtl a\r\n"
                                     "f 1/1 2/2 3/3\r\n");
  const TexturedMesh m = read_obj(obj);
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[1], Vec3(1, 0, 0));
  EXPECT_TRUE(std::signbit(m.positions[2].z()));
  ASSERT_EQ(m.faces.size(), 1u);
  EXPECT_EQ(m.faces[0].source_line, 12);
  EXPECT_EQ(m.materials[0].name, "a");  // no stray '\r'
  EXPECT_EQ(m.materials[0].extra_lines, std::vector<std::string>{"\tKa 1 1 1 1"});
  EXPECT_EQ(m.pages[0].image_path, (fs::path(dir) / "t.png").string());
  EXPECT_EQ(m.pages[0].width, 5);
}

TEST(ObjRead, GroupsObjectsAndSmoothing) {
  const std::string dir = tt::temp_dir();
  const std::string obj = write_text(dir, "g.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                     "f 1 2 3\n"        // 4: no group
                                     "g roof  top\n"    // 5
                                     "s 1\n"
                                     "f 1 2 3\n"        // 7: group 0
                                     "o building\n"
                                     "s off\n"
                                     "f 1 2 3\n"        // 10: group 1
                                     "g roof  top\n"
                                     "f 1 2 3\n"        // 12: group 0 again
                                     "g\n"
                                     "f 1 2 3\n");      // 14: default group
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.groups, (std::vector<std::string>{"g roof  top", "o building"}));
  ASSERT_EQ(m.faces.size(), 5u);
  const int expected[5] = {kNoIndex, 0, 1, 0, kNoIndex};
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(m.faces[i].group, expected[i]) << i;
}

TEST(ObjRead, UntexturedFacesAreKeptWithoutPage) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "two.mtl", kTwoPageMtl);
  const std::string obj = write_text(dir, "mixed.obj",
                                     "mtllib two.mtl\n"
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                     "f 1 2 3\n"
                                     "usemtl red\n"
                                     "f 1/1 2/2 3/3\n"
                                     "f 3 2 1\n");
  const TexturedMesh m = read_obj(obj, no_textures());
  ASSERT_EQ(m.faces.size(), 3u);
  EXPECT_EQ(m.faces[0].material, kNoIndex);
  EXPECT_EQ(m.faces[0].page, kNoPage);
  EXPECT_EQ(m.faces[1].page, 0);
  EXPECT_EQ(m.faces[2].material, 0);
  EXPECT_EQ(m.faces[2].page, kNoPage);  // no vt: untextured even under a textured material
}

TEST(ObjRead, TwoMaterialsWithTheSameImageAreTwoPages) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "same.mtl", "newmtl a\nmap_Kd t.png\nnewmtl b\nmap_Kd t.png\n");
  tt::write_test_image(dir + "/t.png", 4, 4);
  const std::string obj = write_text(dir, "same.obj", "mtllib same.mtl\n");
  const TexturedMesh m = read_obj(obj);
  ASSERT_EQ(m.pages.size(), 2u);
  EXPECT_EQ(m.pages[0].image_path, m.pages[1].image_path);
  EXPECT_EQ(m.pages[0].material, "a");
  EXPECT_EQ(m.pages[1].material, "b");
}

TEST(ObjRead, MissingTextureAllowedWhenNotRequired) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "two.mtl", kTwoPageMtl);
  const std::string obj = write_text(dir, "two.obj", kTwoPageObj);
  ObjReadOptions o;
  o.require_textures = false;
  const TexturedMesh m = read_obj(obj, o);
  ASSERT_EQ(m.pages.size(), 2u);
  EXPECT_EQ(m.pages[0].width, 0);
  EXPECT_EQ(m.pages[0].height, 0);
  // Required (the default): the error names the MTL line of the map_Kd.
  expect_error_at(obj_error(obj), (fs::path(dir) / "two.mtl").string(), 3, "texture image 'red.png' of material 'red' not found");
}

TEST(ObjRead, UnreadableTextureIsAnErrorAtTheMapKdLine) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "two.mtl", kTwoPageMtl);
  tt::write_test_image(dir + "/red.png", 4, 4);
  write_text(dir, "blue.png", "this is not a PNG");
  const std::string obj = write_text(dir, "two.obj", kTwoPageObj);
  const std::string msg = obj_error(obj);
  expect_error_at(msg, (fs::path(dir) / "two.mtl").string(), 7, "cannot read the texture image header");
  EXPECT_NE(msg.find("blue.png"), std::string::npos) << msg;
}

// Every reader error: the message starts with FILE:LINE: and says what was expected.
struct ErrorCase {
  const char* name;
  const char* obj;
  int line;
  const char* what;
};

class ObjReadError : public ::testing::TestWithParam<ErrorCase> {};

TEST_P(ObjReadError, NamesFileAndLine) {
  const ErrorCase& c = GetParam();
  const std::string dir = tt::temp_dir(std::string("_") + c.name);
  write_text(dir, "ok.mtl", "newmtl a\nKd 1 1 1\n");
  const std::string obj = write_text(dir, "bad.obj", c.obj);
  expect_error_at(obj_error(obj, no_textures()), obj, c.line, c.what);
}

#define TRI "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
INSTANTIATE_TEST_SUITE_P(
    Obj, ObjReadError,
    ::testing::Values(
        ErrorCase{"index_out_of_range", TRI "f 1 2 4\n", 7, "v index 4 out of range (3 v defined so far)"},
        ErrorCase{"negative_out_of_range", TRI "f 1/1 2/2 3/-4\n", 7, "vt index -4 out of range"},
        ErrorCase{"index_zero", TRI "f 0 1 2\n", 7, "v index 0 is invalid"},
        ErrorCase{"normal_out_of_range", TRI "f 1//1 2//1 3//1\n", 7, "vn index 1 out of range (0 vn"},
        ErrorCase{"nan_position", "v 0 nan 0\n", 1, "expected a finite number, found 'nan' (y of v)"},
        ErrorCase{"inf_texcoord", "vt inf 0\n", 1, "expected a finite number, found 'inf' (u of vt)"},
        ErrorCase{"huge_number", "v 1e999 0 0\n", 1, "outside the range of a double"},
        ErrorCase{"bad_token", "v 0 1.5x 0\n", 1, "expected a number, found '1.5x' (y of v)"},
        ErrorCase{"too_few_coords", "\nv 0 1\n", 2, "expected a number (z of v) before the end of the line"},
        ErrorCase{"v_five_numbers", "v 0 1 2 0.5 0.5\n", 1, "or 6 (x y z r g b), found 5"},
        ErrorCase{"v_eight_numbers", "v 0 1 2 1 0.5 0.5 0.5 1\n", 1, "found more"},
        ErrorCase{"v_w_not_one", "v 0 1 2 2\n", 1, "w != 1"},
        ErrorCase{"colour_after_plain", "v 0 0 0\nv 1 0 0\nv 0 1 0 0.5 0.5 0.5\n", 3,
                  "a vertex colour (v x y z r g b), but the first v line (line 1) has none"},
        ErrorCase{"plain_after_colour", "# c\nv 0 0 0 1 0 0\nv 1 0 0\n", 3,
                  "no vertex colour, but the first v line (line 2) has one"},
        ErrorCase{"vt_one_number", "vt 0.5\n", 1, "expected a number (v of vt)"},
        ErrorCase{"vt_four_numbers", "vt 0 0 0 0\n", 1, "expected 2 or 3 numbers after vt"},
        ErrorCase{"vn_four_numbers", "vn 0 0 1 1\n", 1, "expected 3 numbers after vn"},
        ErrorCase{"bad_index_token", TRI "f 1 2 x\n", 7, "expected an integer v index, found 'x'"},
        ErrorCase{"bad_corner", TRI "f 1/1/1/1 2 3\n", 7, "expected a face corner"},
        ErrorCase{"two_corners", TRI "f 1 2\n", 7, "expected a face with at least 3 corners, found 2"},
        ErrorCase{"mixed_vt", TRI "f 1/1 2/2 3\n", 7, "face mixes corners with and without texture coordinates"},
        ErrorCase{"mixed_vn", "v 0 0 0\nvn 0 0 1\nf 1//1 1//1 1\n", 3, "face mixes corners with and without normals"},
        ErrorCase{"missing_mtl", "# x\nmtllib nowhere.mtl\n", 2, "material library 'nowhere.mtl' not found"},
        ErrorCase{"unknown_material", "mtllib ok.mtl\nusemtl b\n", 2, "usemtl of unknown material 'b'"},
        ErrorCase{"usemtl_before_mtllib", "usemtl a\nmtllib ok.mtl\n", 1, "usemtl of unknown material 'a' (no mtllib before it)"},
        ErrorCase{"usemtl_without_name", "usemtl\n", 1, "expected a material name after usemtl"},
        ErrorCase{"mtllib_without_name", "mtllib  \n", 1, "expected one or more MTL file names"},
        ErrorCase{"bad_smoothing", "s maybe\n", 1, "expected a smoothing group number or 'off'"},
        ErrorCase{"unsupported_line", TRI "l 1 2\n", 7, "unsupported statement 'l'"},
        ErrorCase{"unknown_statement", "vx 1 2 3\n", 1, "unknown statement 'vx'"}));
#undef TRI

struct MtlErrorCase {
  const char* name;
  const char* mtl;
  int line;
  const char* what;
};

class MtlReadError : public ::testing::TestWithParam<MtlErrorCase> {};

TEST_P(MtlReadError, NamesMtlFileAndLine) {
  const MtlErrorCase& c = GetParam();
  const std::string dir = tt::temp_dir(std::string("_") + c.name);
  const std::string mtl = write_text(dir, "bad.mtl", c.mtl);
  write_text(dir, "first.mtl", "newmtl a\n");
  const std::string obj = write_text(dir, "m.obj", "mtllib first.mtl bad.mtl\n");
  expect_error_at(obj_error(obj, no_textures()), mtl, c.line, c.what);
}

INSTANTIATE_TEST_SUITE_P(
    Mtl, MtlReadError,
    ::testing::Values(
        MtlErrorCase{"statement_before_newmtl", "# ok\nKd 1 1 1\n", 2, "expected 'newmtl' before 'Kd'"},
        MtlErrorCase{"newmtl_without_name", "newmtl\n", 1, "expected a material name after newmtl"},
        MtlErrorCase{"duplicate_material", "newmtl b\nnewmtl a\n", 2, "material 'a' defined twice (first at "},
        MtlErrorCase{"unknown_option", "newmtl b\nmap_Kd -zz 1 t.png\n", 2, "unknown map_Kd option '-zz'"},
        MtlErrorCase{"option_not_numeric", "newmtl b\nmap_Kd -bm x t.png\n", 2, "map_Kd option -bm: expected a number, found 'x'"},
        MtlErrorCase{"option_missing_argument", "newmtl b\nmap_Kd -clamp\n", 2, "expected 1 argument(s) after map_Kd option -clamp"},
        MtlErrorCase{"clamp_not_on_or_off", "newmtl b\nmap_Kd -clamp yes t.png\n", 2, "map_Kd option -clamp: expected on or off, found 'yes'"},
        MtlErrorCase{"map_without_file", "newmtl b\nmap_Kd -bm 1\n", 2, "expected a texture file name after map_Kd"},
        MtlErrorCase{"second_map", "newmtl b\nmap_Kd t.png\n\nmap_Kd u.png\n", 4, "second map_Kd for material 'b' (first at line 2)"}));

TEST(ObjRead, MissingObjFileNamesThePath) {
  const std::string dir = tt::temp_dir();
  const std::string path = dir + "/absent.obj";
  const std::string msg = obj_error(path);
  EXPECT_NE(msg.find("cannot open " + path), std::string::npos) << msg;
}

// ------------------------------------------------------------------------------------------------
// Writer.

TEST(FormatDouble, ShortestFormReadsBackBitIdentical) {
  const double values[] = {0.0, -0.0, 1.0, -1.5, 0.1, 1.0 / 3.0, 2.0 / 3.0, 1e-300, 4.9e-324,
                           std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                           19.402294158935547, 1604.5255126953125, 0.82058578729629517, 123456789.123456789};
  for (double d : values) {
    const std::string s = format_double(d);
    double back = 1234.5;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), back);
    ASSERT_EQ(r.ec, std::errc()) << s;
    EXPECT_EQ(r.ptr, s.data() + s.size()) << s;
    EXPECT_EQ(std::memcmp(&back, &d, sizeof d), 0) << s;  // bit-identical, incl. the sign of zero
    EXPECT_EQ(std::strtod(s.c_str(), nullptr), d) << s;   // what other OBJ readers use
  }
  EXPECT_EQ(format_double(0.1), "0.1");
  EXPECT_EQ(format_double(1.0), "1");
  EXPECT_EQ(format_double(-0.0), "-0");
  EXPECT_EQ(format_double(1604.5255126953125), "1604.5255126953125");
}

namespace {

/// A mesh exercising every writer feature: untextured faces first, groups, two pages, a material
/// without image, normals, awkward doubles.
TexturedMesh writer_mesh(const std::string& image_dir) {
  TexturedMesh m;
  m.positions = {Vec3(0.1, 1.0 / 3.0, -0.0), Vec3(1e-300, 2, 3), Vec3(19.402294158935547, 1604.5255126953125, 5),
                 Vec3(-7, 8.25, 9)};
  m.texcoords = {Vec2(0.82058578729629517, 0.5527082085609436), Vec2(1, 0), Vec2(2.0 / 3.0, 1e-7)};
  m.normals = {Vec3(0, 0, 1), Vec3(0.6, 0.8, 0)};
  Material a;
  a.name = "page a";
  a.extra_lines = {"Ka 1 1 1 1", "  Kd 1 1 1 1"};
  a.map_kd = "old/a.jpg";
  a.map_kd_options = "-bm 1";
  Material plain;
  plain.name = "plain";
  plain.extra_lines = {"Kd 0.5 0.5 0.5"};
  Material b;
  b.name = "b";
  m.materials = {a, plain, b};
  m.pages = {Page{"page a", image_dir + "/out_a.png", 4, 4}, Page{"b", image_dir + "/out_b.jpg", 8, 8}};
  m.groups = {"g roof", "o building 2"};
  auto face = [&](std::array<int, 3> v, std::array<int, 3> vt, std::array<int, 3> vn, int mat, int page, int group) {
    Face f;
    f.v = v;
    f.vt = vt;
    f.vn = vn;
    f.material = mat;
    f.page = page;
    f.group = group;
    m.faces.push_back(f);
  };
  const std::array<int, 3> none{kNoIndex, kNoIndex, kNoIndex};
  face({0, 1, 2}, none, none, kNoIndex, kNoPage, kNoIndex);        // f v
  face({0, 1, 2}, none, {0, 0, 1}, kNoIndex, kNoPage, 0);          // f v//vn
  face({1, 2, 3}, {0, 1, 2}, none, 0, 0, 0);                        // f v/vt
  face({3, 2, 1}, {2, 1, 0}, {1, 1, 0}, 2, 1, 1);                   // f v/vt/vn
  face({0, 2, 3}, {0, 1, 2}, none, 1, kNoPage, 1);                  // vt on a material without image
  face({0, 1, 3}, none, none, 0, kNoPage, kNoIndex);                // untextured, default group
  return m;
}

void expect_same_mesh(const TexturedMesh& a, const TexturedMesh& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i)
    EXPECT_EQ(std::memcmp(a.positions[i].data(), b.positions[i].data(), 3 * sizeof(double)), 0) << "position " << i;
  ASSERT_EQ(a.texcoords.size(), b.texcoords.size());
  for (size_t i = 0; i < a.texcoords.size(); ++i)
    EXPECT_EQ(std::memcmp(a.texcoords[i].data(), b.texcoords[i].data(), 2 * sizeof(double)), 0) << "texcoord " << i;
  ASSERT_EQ(a.normals.size(), b.normals.size());
  for (size_t i = 0; i < a.normals.size(); ++i) EXPECT_EQ(a.normals[i], b.normals[i]) << "normal " << i;
  ASSERT_EQ(a.faces.size(), b.faces.size());
  for (size_t i = 0; i < a.faces.size(); ++i) {
    EXPECT_EQ(a.faces[i].v, b.faces[i].v) << "face " << i;
    EXPECT_EQ(a.faces[i].vt, b.faces[i].vt) << "face " << i;
    EXPECT_EQ(a.faces[i].vn, b.faces[i].vn) << "face " << i;
    EXPECT_EQ(a.faces[i].material, b.faces[i].material) << "face " << i;
    EXPECT_EQ(a.faces[i].page, b.faces[i].page) << "face " << i;
    EXPECT_EQ(a.faces[i].group, b.faces[i].group) << "face " << i;
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    EXPECT_EQ(a.materials[i].name, b.materials[i].name);
    EXPECT_EQ(a.materials[i].extra_lines, b.materials[i].extra_lines);
    EXPECT_EQ(a.materials[i].map_kd_options, b.materials[i].map_kd_options);
  }
  ASSERT_EQ(a.pages.size(), b.pages.size());
  for (size_t i = 0; i < a.pages.size(); ++i) {
    EXPECT_EQ(a.pages[i].material, b.pages[i].material);
    EXPECT_EQ(fs::path(a.pages[i].image_path).filename(), fs::path(b.pages[i].image_path).filename());
  }
  EXPECT_EQ(a.groups, b.groups);
}

}  // namespace

TEST(ObjWrite, RoundTripIsBitIdenticalAndKeepsFacesMaterialsGroups) {
  const std::string dir = tt::temp_dir();
  const TexturedMesh m = writer_mesh(dir + "/elsewhere");
  const std::string obj = dir + "/out.obj";
  write_obj(m, obj);
  const TexturedMesh back = read_obj(obj, no_textures());
  expect_same_mesh(m, back);
  EXPECT_EQ(back.pages[0].image_path, (fs::path(dir) / "out_a.png").string());  // beside the MTL
  EXPECT_EQ(count_temporaries(dir), 0);

  // Written twice, the output is identical (deterministic).
  const std::string text = read_text(obj);
  write_obj(back, obj);
  EXPECT_EQ(read_text(obj), text);
}

TEST(ObjWrite, VertexColoursRoundTripBitIdenticalWithTheirPositions) {
  const std::string dir = tt::temp_dir();
  TexturedMesh m = writer_mesh(dir + "/elsewhere");
  for (size_t i = 0; i < m.positions.size(); ++i) m.colors.emplace_back(0.1 * static_cast<double>(i), 1.0 / 3.0, 0.7);
  const std::string obj = dir + "/out.obj";
  write_obj(m, obj);
  const TexturedMesh back = read_obj(obj, no_textures());
  expect_same_mesh(m, back);
  ASSERT_EQ(back.colors.size(), m.colors.size());
  for (size_t i = 0; i < m.colors.size(); ++i) EXPECT_EQ(back.colors[i], m.colors[i]) << "colour " << i;
  EXPECT_NE(read_text(obj).find(" 0 0.3333333333333333 0.7\nv "), std::string::npos) << read_text(obj);  // colour of position 0

  // One colour per position or none: anything else is refused before a file is written.
  m.colors.pop_back();
  const std::string bad = dir + "/bad.obj";
  try {
    write_obj(m, bad);
    ADD_FAILURE() << "a mesh with fewer colours than positions was written";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("vertex colours for"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(bad));
}

TEST(ObjWrite, TextFormOfFacesMaterialsAndMtl) {
  const std::string dir = tt::temp_dir();
  const TexturedMesh m = writer_mesh(dir);
  const std::string obj = dir + "/out.obj";
  write_obj(m, obj);
  const std::string text = read_text(obj);
  EXPECT_NE(text.find("mtllib out.mtl\n"), std::string::npos) << text;
  EXPECT_NE(text.find("v 0.1 0.3333333333333333 -0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("v 19.402294158935547 1604.5255126953125 5\n"), std::string::npos) << text;
  EXPECT_NE(text.find("vt 0.6666666666666666 1e-07\n"), std::string::npos) << text;
  EXPECT_NE(text.find("vn 0.6 0.8 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nf 1 2 3\ng roof\nf 1//1 2//1 3//2\nusemtl page a\nf 2/1 3/2 4/3\n"
                      "o building 2\nusemtl b\nf 4/3/2 3/2/2 2/1/1\nusemtl plain\nf 1/1 3/2 4/3\n"
                      "g\nusemtl page a\nf 1 2 4\n"),
            std::string::npos)
      << text;
  const std::string mtl = read_text(dir + "/out.mtl");
  EXPECT_NE(mtl.find("newmtl page a\nKa 1 1 1 1\n  Kd 1 1 1 1\nmap_Kd -bm 1 out_a.png\n"), std::string::npos) << mtl;
  EXPECT_NE(mtl.find("newmtl plain\nKd 0.5 0.5 0.5\n\n"), std::string::npos) << mtl;
  EXPECT_NE(mtl.find("newmtl b\nmap_Kd out_b.jpg\n"), std::string::npos) << mtl;
}

TEST(ObjWrite, CustomMtlNameAndNoMtlWithoutMaterials) {
  const std::string dir = tt::temp_dir();
  ObjWriteOptions o;
  o.mtl_name = "lib.mtl";
  write_obj(writer_mesh(dir), dir + "/a.obj", o);
  EXPECT_NE(read_text(dir + "/a.obj").find("mtllib lib.mtl\n"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/lib.mtl"));
  EXPECT_FALSE(fs::exists(dir + "/a.mtl"));

  TexturedMesh bare;
  bare.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  bare.faces.resize(1);
  bare.faces[0].v = {0, 1, 2};
  write_obj(bare, dir + "/bare.obj");
  EXPECT_EQ(read_text(dir + "/bare.obj").find("mtllib"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir + "/bare.mtl"));
  EXPECT_EQ(read_obj(dir + "/bare.obj").faces.size(), 1u);
}

TEST(ObjWrite, RefusesProtectedPathsComparedCanonically) {
  const std::string dir = tt::temp_dir();
  write_text(dir, "in/input.obj", "original obj");
  write_text(dir, "in/input.mtl", "original mtl");
  fs::create_symlink(fs::path(dir) / "in", fs::path(dir) / "link");
  const TexturedMesh m = writer_mesh(dir);
  ObjWriteOptions o;
  o.protected_paths = {dir + "/in/input.obj", dir + "/in/input.mtl"};
  // Same file spelled differently: through "..", "." and a symbolic link.
  for (const std::string& target : {dir + "/in/../in/input.obj", dir + "/link/./input.obj"}) {
    try {
      write_obj(m, target, o);
      ADD_FAILURE() << "wrote onto a protected path " << target;
    } catch (const ObjError& e) {
      EXPECT_NE(std::string(e.what()).find("refusing to overwrite the protected file " + dir + "/in/input.obj"), std::string::npos) << e.what();
    }
  }
  // The OBJ is new but its MTL would overwrite the input MTL.
  ObjWriteOptions o2 = o;
  o2.mtl_name = "input.mtl";
  try {
    write_obj(m, dir + "/in/output.obj", o2);
    ADD_FAILURE() << "wrote onto the protected MTL";
  } catch (const ObjError& e) {
    EXPECT_NE(std::string(e.what()).find("refusing to overwrite the protected file " + dir + "/in/input.mtl"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(dir + "/in/input.obj"), "original obj");
  EXPECT_EQ(read_text(dir + "/in/input.mtl"), "original mtl");
  EXPECT_FALSE(fs::exists(dir + "/in/output.obj"));
  // A path that is not protected is written.
  write_obj(m, dir + "/in/output.obj", o);
  EXPECT_TRUE(fs::exists(dir + "/in/output.obj"));
}

TEST(ObjWrite, RejectsInconsistentMeshesWithoutWriting) {
  const std::string dir = tt::temp_dir();
  struct Case {
    const char* what;
    std::function<void(TexturedMesh&)> damage;
  };
  const std::vector<Case> cases = {
      {"position 1 is not finite", [](TexturedMesh& m) { m.positions[1].y() = std::nan(""); }},
      {"texture coordinate 2 is not finite", [](TexturedMesh& m) { m.texcoords[2].x() = INFINITY; }},
      {"has an index out of range", [](TexturedMesh& m) { m.faces[2].vt[1] = 3; }},
      {"has an index out of range", [](TexturedMesh& m) { m.faces[0].v[0] = -5; }},
      {"mixes corners with and without", [](TexturedMesh& m) { m.faces[2].vt[2] = kNoIndex; }},
      {"has page 1 but its material and texture coordinates give page 0", [](TexturedMesh& m) { m.faces[2].page = 1; }},
      {"has no material but follows faces with one", [](TexturedMesh& m) { m.faces[5].material = kNoIndex; }},
      {"has group 7 out of range", [](TexturedMesh& m) { m.faces[1].group = 7; }},
      {"names material 'nope', which is not in the mesh", [](TexturedMesh& m) { m.pages[1].material = "nope"; }},
      {"share material 'b'", [](TexturedMesh& m) { m.pages[0].material = "b"; }},
      {"two materials named 'plain'", [](TexturedMesh& m) { m.materials[2].name = "plain"; }},
      {"material 1 has name ' plain' (expected non-empty", [](TexturedMesh& m) { m.materials[1].name = " plain"; }},
      {"has extra line 'map_Kd x.png'", [](TexturedMesh& m) { m.materials[1].extra_lines.push_back("map_Kd x.png"); }},
      {"has extra line 'Kd 1?newmtl c'", [](TexturedMesh& m) { m.materials[1].extra_lines.push_back("Kd 1\nnewmtl c"); }},
      {"group 0 is 'roof' (expected a statement 'g NAME' or 'o NAME'", [](TexturedMesh& m) { m.groups[0] = "roof"; }},
  };
  for (const Case& c : cases) {
    TexturedMesh m = writer_mesh(dir);
    c.damage(m);
    try {
      write_obj(m, dir + "/out.obj");
      ADD_FAILURE() << "no error for: " << c.what;
    } catch (const ObjError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(dir + "/out.obj: ", 0), 0u) << msg;
      EXPECT_NE(msg.find(c.what), std::string::npos) << msg;
    }
    EXPECT_FALSE(fs::exists(dir + "/out.obj")) << c.what;
    EXPECT_FALSE(fs::exists(dir + "/out.mtl")) << c.what;
  }
  EXPECT_EQ(count_temporaries(dir), 0);
}

TEST(WriteFileAtomic, ReplacesContentAndFailsCleanlyNamingTheFile) {
  const std::string dir = tt::temp_dir();
  const std::string p = dir + "/f.txt";
  write_file_atomic(p, "first");
  EXPECT_EQ(read_text(p), "first");
  write_file_atomic(p, "second, longer");
  EXPECT_EQ(read_text(p), "second, longer");
  EXPECT_EQ(count_temporaries(dir), 0);
  const std::string bad = dir + "/no/such/folder/f.txt";
  try {
    write_file_atomic(bad, "x");
    ADD_FAILURE() << "wrote into a missing folder";
  } catch (const ObjError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(bad + ": ", 0), 0u) << e.what();
  }
  // A folder where the file should be: the rename fails, the temporary is removed.
  fs::create_directories(dir + "/sub/target");
  fs::create_directories(dir + "/sub/target/inner");
  EXPECT_THROW(write_file_atomic(dir + "/sub/target", "x"), ObjError);
  EXPECT_EQ(count_temporaries(dir + "/sub"), 0);
}

// Random byte edits of a valid OBJ and MTL: each result either reads into a consistent mesh or
// fails with an ObjError naming a file and line; nothing else (no crash, no other exception).
TEST(ObjRead, MutatedFilesReadOrFailWithFileAndLine) {
  const std::string dir = tt::temp_dir();
  const std::string base_mtl = "newmtl a\nKd 1 1 1 1\nmap_Kd -bm 1 t.png\nnewmtl b\nKa 1 1 1\n";
  const std::string base_obj =
      "mtllib m.mtl\n# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
      "g top\nusemtl a\nf 1/1/1 2/2/1 3/3/1 4/4/1\no x\ns 1\nusemtl b\nf -4/-4/ -3/-3/ -2/-2/\nf 1//1 2//1 3//1\nf 1 3 4\n";
  static const char kAlphabet[] = "/ -+0123456789.e\n\r\t#fvtnsgou\0x";
  const std::string alphabet(kAlphabet, sizeof kAlphabet - 1);  // includes a NUL byte
  uint32_t seed = 20240601u;
  auto next = [&seed](uint32_t n) {
    seed = seed * 1664525u + 1013904223u;
    return (seed >> 8) % n;
  };
  int ok = 0, failed = 0;
  for (int iter = 0; iter < 400; ++iter) {
    std::string obj = base_obj, mtl = base_mtl;
    std::string& target = iter % 4 == 3 ? mtl : obj;
    const int edits = 1 + static_cast<int>(next(3));
    for (int e = 0; e < edits && !target.empty(); ++e) {
      const size_t at = next(static_cast<uint32_t>(target.size()));
      const char c = alphabet[next(static_cast<uint32_t>(alphabet.size()))];
      switch (next(3)) {
        case 0: target[at] = c; break;
        case 1: target.erase(at, 1); break;
        default: target.insert(target.begin() + static_cast<std::ptrdiff_t>(at), c); break;
      }
    }
    write_text(dir, "m.mtl", mtl);
    const std::string path = write_text(dir, "m.obj", obj);
    try {
      const TexturedMesh m = read_obj(path, no_textures());
      ++ok;
      for (const Face& f : m.faces)
        for (size_t k = 0; k < 3; ++k) {
          ASSERT_LT(static_cast<size_t>(f.v[k]), m.positions.size());
          if (f.vt[k] != kNoIndex) { ASSERT_LT(static_cast<size_t>(f.vt[k]), m.texcoords.size()); }
          if (f.vn[k] != kNoIndex) { ASSERT_LT(static_cast<size_t>(f.vn[k]), m.normals.size()); }
          ASSERT_EQ(f.vt[k] == kNoIndex, f.vt[0] == kNoIndex);
        }
    } catch (const ObjError& e) {
      ++failed;
      const std::string msg = e.what();
      const size_t colon = msg.find(".obj:") != std::string::npos ? msg.find(".obj:") + 5 : msg.find(".mtl:") + 5;
      ASSERT_GT(colon, 5u) << msg;
      ASSERT_TRUE(colon < msg.size() && std::isdigit(static_cast<unsigned char>(msg[colon]))) << msg;
    }
  }
  EXPECT_GT(ok, 0);
  EXPECT_GT(failed, 0);
}
