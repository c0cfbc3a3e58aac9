// glTF 2.0 / GLB reader and writer on tiny files built with tinygltf's writer and Draco's encoder.
#include "gltf_test_util.h"
#include "stretch_test_util.h"

#include "texdefrag/pipeline/pipeline.h"

#include <nlohmann/json.hpp>

#include <functional>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::gltf_test;
using texdefrag::testing::temp_dir;

namespace {

std::string gltf_error(const std::vector<GltfInput>& in) {
  try {
    read_gltf(in);
  } catch (const GltfError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected GltfError";
  return "";
}
std::string gltf_error(const std::string& path) { return gltf_error(std::vector<GltfInput>{{path, {}, ""}}); }

/// Output paths: every input file re-rooted from `in_dir` to `out_dir`.
GltfOutputPaths reroot(const GltfModel& m, const std::string& in_dir, const std::string& out_dir) {
  GltfOutputPaths p;
  auto map = [in_dir, out_dir](const std::string& f) {
    return (fs::path(out_dir) / fs::path(f).lexically_relative(in_dir)).string();
  };
  for (const auto& i : m.inputs) p.documents.push_back(map(i.path));
  p.map_path = map;
  return p;
}

/// Writes a GltfOutput's files (documents at their paths) and returns the document paths.
std::vector<std::string> commit(const GltfOutput& o, const GltfOutputPaths& p) {
  for (size_t i = 0; i < o.documents.size(); ++i) put_file(p.documents[i], o.documents[i]);
  for (const auto& f : o.files) put_file(f.path, f.bytes);
  return p.documents;
}

/// The input pages as they are (PNG bytes), for an identity write.
std::vector<EncodedPage> same_pages(const GltfModel& m) {
  std::vector<EncodedPage> pages;
  for (const auto& s : m.page_source)
    pages.push_back({s.mime, s.image_file.empty() ? s.embedded : file_bytes(s.image_file)});
  return pages;
}

void expect_same_geometry(const GltfModel& a, const GltfModel& b) {
  ASSERT_EQ(a.mesh.faces.size(), b.mesh.faces.size());
  for (size_t f = 0; f < a.mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = a.mesh.corner_position(f, k);
      const Vec3& q = b.mesh.corner_position(f, k);
      ASSERT_EQ(std::memcmp(p.data(), q.data(), 24), 0) << "face " << f << " corner " << k;
    }
}

tinygltf::Model two_material_model(const std::string& dir) {
  tinygltf::Model m = base_model();
  const int m0 = add_textured_material(m, png_bytes(dir, 64, 64));
  const int m1 = add_textured_material(m, png_bytes(dir, 32, 32));
  m.meshes[0].primitives.push_back(add_primitive(m, grid(3, 2), m0));
  m.meshes[0].primitives.push_back(add_primitive(m, grid(2, 2, 1.5f), m1));
  return m;
}

}  // namespace

TEST(Gltf, ReadsPrimitivesAsFacesAndImagesAsPages) {
  const std::string dir = temp_dir();
  save(two_material_model(dir), dir + "/a.glb");
  const GltfModel g = read_gltf(dir + "/a.glb");
  EXPECT_EQ(g.mesh.faces.size(), 12u + 8u);
  ASSERT_EQ(g.mesh.pages.size(), 2u);
  EXPECT_EQ(g.mesh.pages[0].width, 64);
  EXPECT_EQ(g.mesh.pages[1].width, 32);
  EXPECT_EQ(g.mesh.faces[0].page, 0);
  EXPECT_EQ(g.mesh.faces[12].page, 1);
  EXPECT_EQ(g.face_source[13].primitive, 1);
  EXPECT_EQ(g.face_source[13].triangle, 1);
  // glTF's v runs down, the mesh's v up.
  const GridData gd = grid(3, 2);
  EXPECT_DOUBLE_EQ(g.mesh.texcoords[static_cast<size_t>(g.mesh.faces[0].vt[1])].y(), 1.0 - double(gd.uv[3]));
  EXPECT_EQ(g.mesh.positions[static_cast<size_t>(g.mesh.faces[12].v[0])].z(), 1.5);
  EXPECT_EQ(read_gltf_page(g, 1).width, 32);
}

TEST(Gltf, StripsAndFansAreTriangulatedAsTheSpecSays) {
  const std::string dir = temp_dir();
  tinygltf::Model m = base_model();
  GridData g;
  for (int i = 0; i < 5; ++i) {
    g.pos.insert(g.pos.end(), {float(i), float(i % 2), 0});
    g.uv.insert(g.uv.end(), {float(i) / 5, float(i % 2)});
    g.idx.push_back(static_cast<uint32_t>(i));
  }
  const int mat = add_textured_material(m, png_bytes(dir, 8, 8));
  m.meshes[0].primitives.push_back(add_primitive(m, g, mat, 5));
  m.meshes[0].primitives.push_back(add_primitive(m, g, mat, 6));
  save(m, dir + "/s.glb");
  const GltfModel r = read_gltf(dir + "/s.glb");
  ASSERT_EQ(r.mesh.faces.size(), 6u);
  auto local = [&](size_t f) {
    std::array<int, 3> v = r.mesh.faces[f].v;
    const int base = f < 3 ? 0 : 5;
    return std::array<int, 3>{v[0] - base, v[1] - base, v[2] - base};
  };
  EXPECT_EQ(local(0), (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(local(1), (std::array<int, 3>{1, 3, 2}));  // odd strip triangle: {v_i, v_{i+2}, v_{i+1}}
  EXPECT_EQ(local(2), (std::array<int, 3>{2, 3, 4}));
  EXPECT_EQ(local(3), (std::array<int, 3>{1, 2, 0}));  // fan: {v_{i+1}, v_{i+2}, v_0}
  EXPECT_EQ(local(5), (std::array<int, 3>{3, 4, 0}));
}

TEST(Gltf, IdentityWriteKeepsTheAssetAndValidates) {
  const std::string dir = temp_dir();
  tinygltf::Model m = two_material_model(dir);
  tinygltf::Value::Object ext;
  ext["answer"] = tinygltf::Value(42);
  m.meshes[0].primitives[0].extensions["EXT_test_unknown"] = tinygltf::Value(ext);
  m.extensionsUsed.push_back("EXT_test_unknown");
  save(m, dir + "/in/a.glb");
  const GltfModel g = read_gltf(dir + "/in/a.glb");
  const GltfOutputPaths p = reroot(g, dir + "/in", dir + "/out");
  const GltfOutput o = write_gltf(g, g.mesh, same_pages(g), p);
  commit(o, p);
  const GltfModel back = read_gltf(dir + "/out/a.glb");
  expect_same_geometry(g, back);
  ASSERT_EQ(back.mesh.pages.size(), 2u);
  EXPECT_EQ(back.page_source[0].embedded, g.page_source[0].embedded);
  const auto& j = (*back.documents)[0].json;
  EXPECT_EQ(j["nodes"][0]["matrix"][12], 10);
  EXPECT_EQ(j["nodes"][0]["extras"]["tile"], "t1");
  EXPECT_EQ(j["meshes"][0]["primitives"][0]["extensions"]["EXT_test_unknown"]["answer"], 42);
  EXPECT_EQ(o.report["documents"][0]["rewritten_primitives"], 2);
  for (size_t f = 0; f < g.mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2 a = g.mesh.texcoords[static_cast<size_t>(g.mesh.faces[f].vt[k])];
      const Vec2 b = back.mesh.texcoords[static_cast<size_t>(back.mesh.faces[f].vt[k])];
      EXPECT_NEAR(a.x(), b.x(), 1e-7);
      EXPECT_NEAR(a.y(), b.y(), 1e-7);
    }
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/out/a.glb"});
}

TEST(Gltf, FacesOfOnePrimitiveOnTwoPagesSplitIntoTwoPrimitives) {
  const std::string dir = temp_dir();
  save(two_material_model(dir), dir + "/in/a.glb");
  const GltfModel g = read_gltf(dir + "/in/a.glb");
  TexturedMesh out = g.mesh;
  out.pages.resize(2);
  // Halve every texture coordinate; odd faces of the first primitive go to page 1.
  for (auto& t : out.texcoords) t *= 0.5;
  for (size_t f = 0; f < 12; f += 2) out.faces[f + 1].page = 1;
  for (size_t f = 12; f < out.faces.size(); ++f) out.faces[f].page = 0;
  std::vector<EncodedPage> pages = {{"image/png", png_bytes(dir, 16, 16)}, {"image/png", png_bytes(dir, 8, 8)}};
  const GltfOutputPaths p = reroot(g, dir + "/in", dir + "/out");
  const GltfOutput o = write_gltf(g, out, pages, p);
  commit(o, p);
  const GltfModel back = read_gltf(dir + "/out/a.glb");
  ASSERT_EQ(back.mesh.faces.size(), out.faces.size());
  const auto& j = (*back.documents)[0].json;
  EXPECT_EQ(j["meshes"][0]["primitives"].size(), 3u);
  EXPECT_EQ(j["textures"].size(), 2u);
  EXPECT_EQ(j["images"].size(), 2u);
  EXPECT_EQ(o.report["documents"][0]["split_primitives"], 1);
  // The even faces of primitive 0 stay in primitive 0, in order; odd ones form primitive 2.
  EXPECT_EQ(back.face_source[0].primitive, 0);
  EXPECT_EQ(back.mesh.positions[static_cast<size_t>(back.mesh.faces[1].v[0])],
            g.mesh.positions[static_cast<size_t>(g.mesh.faces[2].v[0])]);
  EXPECT_EQ(back.mesh.pages[static_cast<size_t>(back.mesh.faces[0].page)].width, 16);
  const Vec2 t = back.mesh.texcoords[static_cast<size_t>(back.mesh.faces[0].vt[0])];
  const Vec2 want = out.texcoords[static_cast<size_t>(out.faces[0].vt[0])];
  EXPECT_NEAR(t.x(), want.x(), 1e-7);
  EXPECT_NEAR(t.y(), want.y(), 1e-7);
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/out/a.glb"});
}

TEST(Gltf, DracoInputDecodesAndIsWrittenUncompressedByDefault) {
  const std::string dir = temp_dir();
  for (bool edgebreaker : {false, true}) {
    const GridData g = grid(4, 3);
    const tinygltf::Model m = draco_grid_model(dir, g, 4, 3, 32, edgebreaker);
    const std::string sub = edgebreaker ? "/eb" : "/seq";
    save(m, dir + sub + "/in/d.glb");
    const GltfModel r = read_gltf(dir + sub + "/in/d.glb");
    ASSERT_EQ(r.mesh.faces.size(), g.idx.size() / 3);
    EXPECT_EQ(r.stats["draco_primitives"], 1);
    const auto& prim = (*r.documents)[0].primitives[0];
    EXPECT_TRUE(prim.position_quantization.valid);
    EXPECT_EQ(prim.position_quantization.bits, 14);
    // Every decoded position lies within a quantisation step of a grid point.
    for (const Vec3& q : r.mesh.positions) EXPECT_NEAR(q.x(), std::round(q.x()), 4.0 / (1 << 14) + 1e-6);

    const GltfOutputPaths paths = reroot(r, dir + sub + "/in", dir + sub + "/none");
    commit(write_gltf(r, r.mesh, same_pages(r), paths), paths);
    const GltfModel plain = read_gltf(dir + sub + "/none/d.glb");
    expect_same_geometry(r, plain);
    EXPECT_EQ(plain.stats["draco_primitives"], 0);
    EXPECT_FALSE((*plain.documents)[0].json.contains("extensionsRequired"));
    TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + sub + "/none/d.glb"});

    // Lossless and input-quantised Draco output decode to the same positions, in the same order.
    for (DracoOutput mode : {DracoOutput::Lossless, DracoOutput::Quantized}) {
      GltfWriteOptions wo;
      wo.draco = mode;
      const std::string o = dir + sub + (mode == DracoOutput::Lossless ? "/lossless" : "/quantized");
      const GltfOutputPaths pp = reroot(r, dir + sub + "/in", o);
      const GltfOutput out = write_gltf(r, r.mesh, same_pages(r), pp, wo);
      EXPECT_EQ(out.report["documents"][0]["draco_positions_changed"], 0);
      commit(out, pp);
      const GltfModel back = read_gltf(o + "/d.glb");
      EXPECT_EQ(back.stats["draco_primitives"], 1);
      expect_same_geometry(r, back);
      TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{o + "/d.glb"});
    }
  }
}

TEST(Gltf, QuantizedDracoOnUncompressedInputIsLossyAndCounted) {
  const std::string dir = temp_dir();
  tinygltf::Model m = base_model();
  GridData g = grid(3, 3);
  for (auto& v : g.pos) v = v * 0.3331f + 0.0123f;
  m.meshes[0].primitives.push_back(add_primitive(m, g, add_textured_material(m, png_bytes(dir, 16, 16))));
  save(m, dir + "/in/q.glb");
  const GltfModel r = read_gltf(dir + "/in/q.glb");
  GltfWriteOptions wo;
  wo.draco = DracoOutput::Quantized;
  wo.draco_position_bits = 8;
  const GltfOutput out = write_gltf(r, r.mesh, same_pages(r), reroot(r, dir + "/in", dir + "/out"), wo);
  EXPECT_GT(out.report["documents"][0]["draco_positions_changed"].get<int>(), 0);
}

TEST(Gltf, SeveralFilesSharingOneImageShareOnePageAndOneOutputImage) {
  const std::string dir = temp_dir();
  fs::create_directories(dir + "/in");
  texdefrag::testing::write_test_image(dir + "/in/atlas.png", 64, 64);
  for (int i = 0; i < 2; ++i) {
    tinygltf::Model m = base_model();
    m.meshes[0].primitives.push_back(add_primitive(m, grid(2, 2, float(i)), add_textured_material(m, {}, "../atlas.png")));
    save(m, dir + "/in/lod/t" + std::to_string(i) + ".glb");
  }
  const GltfModel g = read_gltf({{dir + "/in/lod/t0.glb", {}, ""}, {dir + "/in/lod/t1.glb", {}, ""}});
  ASSERT_EQ(g.mesh.pages.size(), 1u);
  EXPECT_EQ(g.mesh.faces.back().page, 0);
  EXPECT_EQ(g.face_source.back().file, 1);
  const GltfOutputPaths p = reroot(g, dir + "/in", dir + "/out");
  const GltfOutput o = write_gltf(g, g.mesh, same_pages(g), p);
  ASSERT_EQ(o.files.size(), 1u);
  EXPECT_EQ(o.files[0].path, dir + "/out/atlas.png");
  commit(o, p);
  const GltfModel back = read_gltf(dir + "/out/lod/t1.glb");
  EXPECT_EQ((*back.documents)[0].json["images"][0]["uri"], "../atlas.png");
  TEXDEFRAG_EXPECT_VALID_GLTF((std::vector<std::string>{dir + "/out/lod/t0.glb", dir + "/out/lod/t1.glb"}));
}

TEST(Gltf, Ktx2OnlyTextureIsAnErrorNamingTheFileUnlessAJpegOrPngIsBeside) {
  const std::string dir = temp_dir();
  tinygltf::Model m = base_model();
  m.meshes[0].primitives.push_back(add_primitive(m, grid(1, 1), add_textured_material(m, {}, "page.ktx2")));
  // Make texture 0 a KHR_texture_basisu texture without a core source.
  tinygltf::Value::Object b;
  b["source"] = tinygltf::Value(0);
  m.textures[0].source = -1;
  m.textures[0].extensions["KHR_texture_basisu"] = tinygltf::Value(b);
  m.images[0].name = "page_full.png";
  m.extensionsUsed = m.extensionsRequired = {"KHR_texture_basisu"};
  save(m, dir + "/k.glb");
  put_file(dir + "/page.ktx2", std::string("\xABKTX 20\xBB\r\n\x1a\n", 12) + std::string(64, '\0'));
  const std::string e = gltf_error(dir + "/k.glb");
  EXPECT_NE(e.find("k.glb: mesh 0 primitive 0"), std::string::npos) << e;
  EXPECT_NE(e.find("KHR_texture_basisu"), std::string::npos) << e;
  EXPECT_NE(e.find("page_full.png"), std::string::npos) << e;  // where it looked
  texdefrag::testing::write_test_image(dir + "/page_full.png", 16, 8);
  const GltfModel g = read_gltf(dir + "/k.glb");
  ASSERT_EQ(g.mesh.pages.size(), 1u);
  EXPECT_EQ(g.mesh.pages[0].width, 16);
  EXPECT_EQ(g.page_source[0].replaces_ktx2, dir + "/page.ktx2");
  // The output has a PNG texture and no KTX2 extension left.
  const GltfOutputPaths p = reroot(g, dir, dir + "/out");
  commit(write_gltf(g, g.mesh, same_pages(g), p), p);
  const GltfModel back = read_gltf(dir + "/out/k.glb");
  const auto& j = (*back.documents)[0].json;
  EXPECT_FALSE(j.contains("extensionsRequired"));
  EXPECT_EQ(j["images"].size(), 1u);
  EXPECT_EQ(j["images"][0]["uri"], "page_full.png");
  EXPECT_FALSE(j["textures"][0].contains("extensions"));
}

TEST(Gltf, MalformedFilesAreErrorsNamingTheFile) {
  const std::string dir = temp_dir();
  save(two_material_model(dir), dir + "/good.glb");
  const std::vector<uint8_t> good = file_bytes(dir + "/good.glb");
  auto variant = [&](const std::string& name, std::vector<uint8_t> b) {
    put_file(dir + "/" + name, std::string(b.begin(), b.end()));
    return gltf_error(dir + "/" + name);
  };
  std::vector<uint8_t> b = good;
  b[0] = 'X';
  EXPECT_NE(variant("magic.glb", b).find("magic.glb: not a GLB (bad magic"), std::string::npos);
  b = good;
  b.resize(b.size() - 10);
  EXPECT_NE(variant("short.glb", b).find("short.glb: GLB header says"), std::string::npos);
  b = good;
  b[8] -= 10;  // header length shorter than the chunk: the BIN chunk runs past the end
  const std::string e = variant("chunk.glb", b);
  EXPECT_NE(e.find("chunk.glb"), std::string::npos) << e;
  EXPECT_EQ(variant("empty.glb", {}).find(dir + "/empty.glb: "), 0u);
}

TEST(Gltf, BadAccessorsAndNonFinitePositionsAreErrors) {
  const std::string dir = temp_dir();
  {
    tinygltf::Model m = base_model();
    GridData g = grid(1, 1);
    g.idx[4] = 99;
    m.meshes[0].primitives.push_back(add_primitive(m, g, add_textured_material(m, png_bytes(dir, 8, 8))));
    save(m, dir + "/idx.glb");
    const std::string e = gltf_error(dir + "/idx.glb");
    EXPECT_NE(e.find("idx.glb: mesh 0 primitive 0: index 99 at position 4 out of range (6 vertices)"), std::string::npos) << e;
  }
  {
    tinygltf::Model m = base_model();
    m.meshes[0].primitives.push_back(add_primitive(m, grid(1, 1), add_textured_material(m, png_bytes(dir, 8, 8))));
    m.accessors[0].count = 1000;  // POSITION past its buffer view
    save(m, dir + "/acc.glb");
    const std::string e = gltf_error(dir + "/acc.glb");
    EXPECT_NE(e.find("acc.glb: accessor 0 (POSITION of mesh 0 primitive 0): 1000 elements"), std::string::npos) << e;
  }
  {
    tinygltf::Model m = base_model();
    GridData g = grid(1, 1);
    g.pos[4] = std::nanf("");
    m.meshes[0].primitives.push_back(add_primitive(m, g, add_textured_material(m, png_bytes(dir, 8, 8))));
    m.accessors[0].minValues.clear();
    m.accessors[0].maxValues.clear();
    save(m, dir + "/nan.glb");
    const std::string e = gltf_error(dir + "/nan.glb");
    EXPECT_NE(e.find("nan.glb: mesh 0 primitive 0: POSITION of vertex 1 is not finite"), std::string::npos) << e;
  }
}

TEST(Gltf, PointsAndLinesWithTexturesAreErrorsWithoutAreKept) {
  const std::string dir = temp_dir();
  tinygltf::Model m = base_model();
  const int mat = add_textured_material(m, png_bytes(dir, 8, 8));
  m.meshes[0].primitives.push_back(add_primitive(m, grid(1, 1), mat));
  GridData lines = grid(1, 1);
  lines.uv.clear();
  m.meshes[0].primitives.push_back(add_primitive(m, lines, -1, 1));
  save(m, dir + "/in/l.glb");
  const GltfModel g = read_gltf(dir + "/in/l.glb");
  EXPECT_EQ(g.mesh.faces.size(), 2u);
  EXPECT_EQ(g.stats["untouched_point_line_primitives"], 1);
  const GltfOutputPaths p = reroot(g, dir + "/in", dir + "/out");
  commit(write_gltf(g, g.mesh, same_pages(g), p), p);
  const GltfModel back = read_gltf(dir + "/out/l.glb");
  const auto& j = (*back.documents)[0].json;
  EXPECT_EQ(j["meshes"][0]["primitives"][1]["mode"], 1);
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/out/l.glb"});

  m.meshes[0].primitives[1].material = mat;
  m.meshes[0].primitives[1].mode = 0;
  save(m, dir + "/p.glb");
  const std::string e = gltf_error(dir + "/p.glb");
  EXPECT_NE(e.find("p.glb: mesh 0 primitive 1: mode POINTS with a textured material"), std::string::npos) << e;
}

TEST(Gltf, GltfJsonWithEmbeddedBuffersRoundTrips) {
  const std::string dir = temp_dir();
  save(two_material_model(dir), dir + "/in/a.gltf");
  const GltfModel g = read_gltf(dir + "/in/a.gltf");
  EXPECT_FALSE((*g.documents)[0].binary);
  const GltfOutputPaths p = reroot(g, dir + "/in", dir + "/out");
  commit(write_gltf(g, g.mesh, same_pages(g), p), p);
  expect_same_geometry(g, read_gltf(dir + "/out/a.gltf"));
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/out/a.gltf"});
}

namespace {

/// The roof of test_osgb's NodeTransformsAreAppliedForMeasuringOnly as glTF data: 8x8 quads, each
/// its own chart, a ridge along y at x = 1 (x scaled by `sx` in the file).
GridData roof(float sx) {
  GridData g;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      const auto base = static_cast<uint32_t>(g.pos.size() / 3);
      for (int c = 0; c < 4; ++c) {
        const int di = c == 1 || c == 2, dj = c >= 2;
        const float x = 0.25f * static_cast<float>(i + di), y = 0.5f * static_cast<float>(j + dj);
        g.pos.insert(g.pos.end(), {sx * x, y, 0.3f * std::min(x, 2.0f - x)});
        g.uv.insert(g.uv.end(), {(static_cast<float>(i) + 0.1f + 0.8f * static_cast<float>(di)) / 8.0f,
                                 (static_cast<float>(j) + 0.1f + 0.8f * static_cast<float>(dj)) / 8.0f});
      }
      for (uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) g.idx.push_back(base + k);
    }
  return g;
}

/// A GLB of the roof (x stored scaled by `sx`) on the mesh of node 1, child of node 0: node 0
/// gets `parent`, node 1 `child` (each a function setting TRS or matrix on the node).
std::string roof_glb(const std::string& path, float sx, const std::function<void(tinygltf::Node&)>& parent,
                     const std::function<void(tinygltf::Node&)>& child) {
  tinygltf::Model m = base_model();
  m.meshes[0].primitives.push_back(add_primitive(m, roof(sx), add_textured_material(m, png_bytes(fs::path(path).parent_path().parent_path().string(), 64, 64))));
  tinygltf::Node& top = m.nodes[0];
  top.mesh = -1;
  top.matrix.clear();
  top.children = {1};
  parent(top);
  tinygltf::Node leaf;
  leaf.mesh = 0;
  child(leaf);
  m.nodes.push_back(leaf);
  save(m, path);
  return path;
}

/// The POSITION bytes of every face corner, in face order, as stored in the file.
std::vector<uint8_t> stored_corner_positions(const std::string& path) {
  const GltfModel g = read_gltf(path);
  std::vector<uint8_t> out;
  for (const auto& P : (*g.documents)[0].primitives)
    for (const auto& a : P.attributes)
      if (a.first == "POSITION")
        for (uint32_t v : P.tri) {
          const size_t n = a.second.elem_size();
          out.insert(out.end(), a.second.data.begin() + static_cast<std::ptrdiff_t>(v * n),
                     a.second.data.begin() + static_cast<std::ptrdiff_t>((v + 1) * n));
        }
  return out;
}

nlohmann::json run_best(const std::string& input, const std::string& out) {
  const PipelineConfig cfg = load_config((fs::path(source_dir()) / "configs" / "best.json").string());
  RunOptions ro;
  ro.input = input;
  ro.output_dir = out;
  return run_pipeline(cfg, ro);
}

}  // namespace

// A node hierarchy scaling x by 2 above a mesh (a child's TRS scale under a translated parent, or
// a matrix): texdefrag measures the mesh as the user sees it (io/measure_transform.h), so every
// stage gives what it gives on the same mesh stored pre-scaled, while the file written keeps the
// stored positions bit for bit. Rigid hierarchies (rotation + translation) read as stored.
TEST(Gltf, NodeTransformsAreAppliedForMeasuringOnly) {
  const std::string dir = temp_dir();
  auto none = [](tinygltf::Node&) {};
  const std::string scaled = roof_glb(dir + "/in/scaled.glb", 1, [](tinygltf::Node& n) { n.translation = {5e5, 30, -4e6}; },
                                      [](tinygltf::Node& n) { n.scale = {2, 1, 1}; });
  const std::string matrix = roof_glb(dir + "/in/matrix.glb", 1, none, [](tinygltf::Node& n) {
    n.matrix = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 7, 8, 9, 1};
  });
  const std::string prescaled = roof_glb(dir + "/in/prescaled.glb", 2, none, none);
  const std::string plain = roof_glb(dir + "/in/plain.glb", 1, none, none);
  const std::string rigid = roof_glb(dir + "/in/rigid.glb", 1, [](tinygltf::Node& n) { n.rotation = {0.1, 0.7, 0.2, 0.3}; },
                                     [](tinygltf::Node& n) {
                                       n.rotation = {0, 0, 0.6, 0.8};
                                       n.translation = {1, 2, 3};
                                     });

  const GltfModel a = read_gltf(scaled), am = read_gltf(matrix), b = read_gltf(prescaled);
  ASSERT_EQ(a.mesh.positions.size(), 256u);
  EXPECT_EQ(a.positions_stretched, 256u);
  EXPECT_EQ(a.stats["positions_stretched"], 256);
  EXPECT_EQ(b.positions_stretched, 0u);
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_EQ(am.mesh.positions, b.mesh.positions);
  const GltfModel r = read_gltf(rigid), p = read_gltf(plain);
  EXPECT_EQ(r.positions_stretched, 0u);
  EXPECT_EQ(r.mesh.positions, p.mesh.positions);  // bit for bit as stored

  const nlohmann::json ra = run_best(scaled, dir + "/out_scaled");
  const nlohmann::json rb = run_best(prescaled, dir + "/out_prescaled");
  const nlohmann::json rp = run_best(plain, dir + "/out_plain");
  texdefrag::testing::expect_stretch_measured(ra, rb, rp, 256);
  EXPECT_EQ(read_gltf(dir + "/out_scaled/scaled.glb").mesh.texcoords, read_gltf(dir + "/out_prescaled/prescaled.glb").mesh.texcoords);
  // Written: the stored, unscaled positions, bit for bit, and the nodes as they were.
  const std::vector<uint8_t> in_stored = stored_corner_positions(scaled), out_stored = stored_corner_positions(dir + "/out_scaled/scaled.glb");
  ASSERT_EQ(in_stored.size(), 128u * 3 * 12);
  EXPECT_EQ(in_stored, out_stored);
  EXPECT_EQ((*read_gltf(dir + "/out_scaled/scaled.glb").documents)[0].json["nodes"], (*a.documents)[0].json["nodes"]);
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/out_scaled/scaled.glb"});
}

TEST(Gltf, BadNodeHierarchiesAreErrorsNamingTheFile) {
  const std::string dir = temp_dir();
  tinygltf::Model m = base_model();
  m.meshes[0].primitives.push_back(add_primitive(m, grid(1, 1), add_textured_material(m, png_bytes(dir, 8, 8))));
  m.nodes[0].children = {0};  // its own child
  save(m, dir + "/cycle.glb");
  std::string e = gltf_error(dir + "/cycle.glb");
  EXPECT_NE(e.find("cycle.glb: node 0 is its own ancestor"), std::string::npos) << e;
}
