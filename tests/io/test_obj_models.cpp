// Named broken models (tests/io/data, each file's header states its expected behaviour) and the
// bit-identical write + read round trip on every real model present under ../shared/data.
#include "io_test_util.h"

#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace texdefrag;
namespace tt = texdefrag::testing;

namespace {

std::string data(const std::string& name) { return std::string(TEXDEFRAG_IO_TEST_DATA) + "/" + name; }

void expect_error(const std::string& msg, const std::string& prefix, const std::string& what) {
  EXPECT_EQ(msg.rfind(prefix, 0), 0u) << msg << "\nexpected prefix " << prefix;
  EXPECT_NE(msg.find(what), std::string::npos) << msg << "\nexpected to contain " << what;
}

}  // namespace

TEST(BrokenModels, DegenerateEdgeIsReadAndReportedByTopology) {
  const TexturedMesh m = read_obj(data("degenerate_edge.obj"));
  ASSERT_EQ(m.faces.size(), 2u);
  EXPECT_EQ(m.faces[1].v, (std::array<int, 3>{1, 2, 2}));
  EXPECT_EQ(m.pages.size(), 1u);
  EXPECT_EQ(m.pages[0].width, 4);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.report.degenerate_faces, 1u);
  EXPECT_EQ(t.face_degenerate[0], 0);
  EXPECT_EQ(t.face_degenerate[1], 1);
}

TEST(BrokenModels, ZeroAreaFaceIsReadAndReportedByTopology) {
  const TexturedMesh m = read_obj(data("zero_area_face.obj"));
  ASSERT_EQ(m.faces.size(), 2u);
  EXPECT_EQ(face_area_3d(m, 1), 0.0);
  EXPECT_DOUBLE_EQ(face_area_3d(m, 0), 0.5);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.report.zero_area_faces, 1u);
  EXPECT_EQ(t.report.degenerate_faces, 0u);
}

TEST(BrokenModels, NonManifoldEdgeIsReadAndReportedByTopology) {
  const TexturedMesh m = read_obj(data("non_manifold.obj"));
  ASSERT_EQ(m.faces.size(), 3u);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.report.non_manifold_edges, 1u);
  EXPECT_EQ(t.opposite_face(0, 0), -1);  // edge (1, 2) has three faces: no single opposite
}

TEST(BrokenModels, DuplicateTexcoordsAreKeptAndWrittenBack) {
  const TexturedMesh m = read_obj(data("duplicate_texcoords.obj"));
  ASSERT_EQ(m.texcoords.size(), 6u);
  EXPECT_EQ(m.texcoords[0], m.texcoords[3]);
  EXPECT_EQ(m.faces[1].vt, (std::array<int, 3>{3, 4, 5}));
  const std::string dir = tt::temp_dir();
  write_obj(m, dir + "/dup.obj");
  ObjReadOptions o;
  o.require_textures = false;
  const TexturedMesh back = read_obj(dir + "/dup.obj", o);
  ASSERT_EQ(back.texcoords.size(), 6u);
  EXPECT_EQ(back.faces[1].vt, m.faces[1].vt);
}

TEST(BrokenModels, MissingTextureIsAnErrorUnlessNotRequired) {
  expect_error(io_test::obj_error(data("missing_texture.obj")), data("missing_texture.mtl") + ":4: ",
               "texture image 'absent_texture.png' of material 'lost' not found");
  ObjReadOptions o;
  o.require_textures = false;
  const TexturedMesh m = read_obj(data("missing_texture.obj"), o);
  ASSERT_EQ(m.pages.size(), 1u);
  EXPECT_EQ(m.pages[0].width, 0);
  EXPECT_EQ(m.faces[0].page, 0);
}

TEST(BrokenModels, NanUvIsAnError) {
  expect_error(io_test::obj_error(data("nan_uv.obj")), data("nan_uv.obj") + ":9: ",
               "expected a finite number, found 'nan' (v of vt)");
}

TEST(BrokenModels, BadIndexIsAnError) {
  expect_error(io_test::obj_error(data("bad_index.obj")), data("bad_index.obj") + ":12: ",
               "v index 9 out of range (3 v defined so far)");
}

// ------------------------------------------------------------------------------------------------
// Real models.

namespace {

/// Counts statements by their keyword with a plain line reader (independent of the parser).
struct LineCounts {
  size_t v = 0, vt = 0, vn = 0, triangles = 0, usemtl = 0;
};
LineCounts count_lines(const std::string& path) {
  LineCounts c;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("v ", 0) == 0) ++c.v;
    else if (line.rfind("vt ", 0) == 0) ++c.vt;
    else if (line.rfind("vn ", 0) == 0) ++c.vn;
    else if (line.rfind("usemtl ", 0) == 0) ++c.usemtl;
    else if (line.rfind("f ", 0) == 0) {
      size_t corners = 0;
      bool in_token = false;
      for (char ch : line.substr(2)) {
        const bool blank = ch == ' ' || ch == '\t' || ch == '\r';
        if (!blank && !in_token) ++corners;
        in_token = !blank;
      }
      c.triangles += corners - 2;
    }
  }
  return c;
}

}  // namespace

TEST(RealModels, ReadWriteReadIsBitIdentical) {
  const std::vector<std::string> models = tt::real_models();
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  for (const std::string& path : models) {
    SCOPED_TRACE(path);
    const auto t0 = std::chrono::steady_clock::now();
    const TexturedMesh m = read_obj(path);
    const double read_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    const LineCounts c = count_lines(path);
    EXPECT_EQ(m.positions.size(), c.v);
    EXPECT_EQ(m.texcoords.size(), c.vt);
    EXPECT_EQ(m.normals.size(), c.vn);
    EXPECT_EQ(m.faces.size(), c.triangles);
    EXPECT_FALSE(m.pages.empty());
    for (const Page& p : m.pages) {
      EXPECT_GT(p.width, 0) << p.image_path;
      EXPECT_GT(p.height, 0) << p.image_path;
    }
    for (const Face& f : m.faces)
      if (f.vt[0] != kNoIndex) { ASSERT_NE(f.page, kNoPage) << "textured face without page, line " << f.source_line; }

    const std::string dir = tt::temp_dir("_" + fs::path(path).stem().string());
    const std::string out = dir + "/" + fs::path(path).filename().string();
    ObjWriteOptions wo;
    wo.protected_paths = {path};
    write_obj(m, out, wo);
    ObjReadOptions ro;
    ro.require_textures = false;  // images are not copied
    ro.read_page_sizes = false;
    const TexturedMesh b = read_obj(out, ro);

    ASSERT_EQ(b.positions.size(), m.positions.size());
    ASSERT_EQ(b.texcoords.size(), m.texcoords.size());
    ASSERT_EQ(b.normals.size(), m.normals.size());
    ASSERT_EQ(b.faces.size(), m.faces.size());
    size_t bad_positions = 0, bad_texcoords = 0, bad_normals = 0, bad_faces = 0;
    for (size_t i = 0; i < m.positions.size(); ++i) bad_positions += !(b.positions[i] == m.positions[i]);
    for (size_t i = 0; i < m.texcoords.size(); ++i) bad_texcoords += !(b.texcoords[i] == m.texcoords[i]);
    for (size_t i = 0; i < m.normals.size(); ++i) bad_normals += !(b.normals[i] == m.normals[i]);
    for (size_t i = 0; i < m.faces.size(); ++i) {
      const Face &x = m.faces[i], &y = b.faces[i];
      bad_faces += !(x.v == y.v && x.vt == y.vt && x.vn == y.vn && x.material == y.material && x.page == y.page &&
                     x.group == y.group);
    }
    EXPECT_EQ(bad_positions, 0u);
    EXPECT_EQ(bad_texcoords, 0u);
    EXPECT_EQ(bad_normals, 0u);
    EXPECT_EQ(bad_faces, 0u);
    ASSERT_EQ(b.materials.size(), m.materials.size());
    for (size_t i = 0; i < m.materials.size(); ++i) {
      EXPECT_EQ(b.materials[i].name, m.materials[i].name);
      EXPECT_EQ(b.materials[i].extra_lines, m.materials[i].extra_lines);
      EXPECT_EQ(b.materials[i].map_kd_options, m.materials[i].map_kd_options);
    }
    ASSERT_EQ(b.pages.size(), m.pages.size());
    for (size_t i = 0; i < m.pages.size(); ++i)
      EXPECT_EQ(fs::path(b.pages[i].image_path).filename(), fs::path(m.pages[i].image_path).filename());
    std::printf("[ info ] %s: %zu faces, %zu pages, read in %.3f s\n", fs::path(path).filename().c_str(),
                m.faces.size(), m.pages.size(), read_s);
  }
}
