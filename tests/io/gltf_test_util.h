// Tiny glTF/GLB files built with tinygltf's own writer (and Draco's encoder) for the glTF and 3D
// Tiles tests, and the Khronos validator as a test oracle.
#pragma once

#include "texdefrag/io/gltf.h"
#include "../../framework/src/io/gltf_internal.h"  // documents' JSON and decoded primitives
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace texdefrag::gltf_test {

inline std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void put_file(const std::string& path, const std::string& bytes) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

/// PNG bytes of a gradient image (through the project's image writer).
inline std::vector<uint8_t> png_bytes(const std::string& dir, int w, int h) {
  const std::string p = dir + "/tmp_page.png";
  texdefrag::testing::write_test_image(p, w, h);
  auto b = file_bytes(p);
  std::filesystem::remove(p);
  return b;
}

/// Appends bytes as a new buffer view of buffer 0 (4-byte aligned); returns the view index.
inline int add_view(tinygltf::Model& m, const void* data, size_t size, int target = 0) {
  if (m.buffers.empty()) m.buffers.emplace_back();
  auto& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = size;
  v.target = target;
  const auto* p = static_cast<const uint8_t*>(data);
  buf.insert(buf.end(), p, p + size);
  m.bufferViews.push_back(v);
  return static_cast<int>(m.bufferViews.size()) - 1;
}

inline int add_accessor(tinygltf::Model& m, int view, int ctype, int type, size_t count, std::vector<double> mn = {},
                        std::vector<double> mx = {}) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.componentType = ctype;
  a.type = type;
  a.count = count;
  a.minValues = std::move(mn);
  a.maxValues = std::move(mx);
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size()) - 1;
}

/// A fragmented grid: nx*ny quads, every triangle its own chart (own vertices), laid out in a
/// row of cells in [0,1]^2 UV space, at height z. Vertex data as glTF floats.
struct GridData {
  std::vector<float> pos, uv;
  std::vector<uint32_t> idx;
};
inline GridData grid(int nx, int ny, float z = 0) {
  GridData g;
  const int nt = nx * ny * 2;
  const int cells = static_cast<int>(std::ceil(std::sqrt(nt)));
  int t = 0;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x)
      for (int h = 0; h < 2; ++h, ++t) {
        const float q[4][2] = {{float(x), float(y)}, {float(x + 1), float(y)}, {float(x + 1), float(y + 1)}, {float(x), float(y + 1)}};
        const int c[3] = {0, h ? 2 : 1, h ? 3 : 2};
        const float cu = float(t % cells) / cells, cv = float(t / cells) / cells, s = 0.8f / cells;
        for (int k = 0; k < 3; ++k) {
          g.pos.insert(g.pos.end(), {q[c[k]][0], q[c[k]][1], z});
          g.uv.insert(g.uv.end(), {cu + s * (q[c[k]][0] - x), cv + s * (1 - (q[c[k]][1] - y))});
          g.idx.push_back(static_cast<uint32_t>(g.idx.size()));
        }
      }
  return g;
}

/// Adds one TRIANGLES primitive (positions, TEXCOORD_0, uint32 indices) to mesh `mesh`.
inline tinygltf::Primitive add_primitive(tinygltf::Model& m, const GridData& g, int material, int mode = 4) {
  float mn[3] = {1e30f, 1e30f, 1e30f}, mx[3] = {-1e30f, -1e30f, -1e30f};
  for (size_t i = 0; i < g.pos.size(); ++i) {
    mn[i % 3] = std::min(mn[i % 3], g.pos[i]);
    mx[i % 3] = std::max(mx[i % 3], g.pos[i]);
  }
  tinygltf::Primitive p;
  p.mode = mode;
  p.material = material;
  const int pv = add_view(m, g.pos.data(), g.pos.size() * 4, 34962);
  p.attributes["POSITION"] = add_accessor(m, pv, 5126, TINYGLTF_TYPE_VEC3, g.pos.size() / 3, {mn[0], mn[1], mn[2]}, {mx[0], mx[1], mx[2]});
  if (!g.uv.empty()) {
    const int uv = add_view(m, g.uv.data(), g.uv.size() * 4, 34962);
    p.attributes["TEXCOORD_0"] = add_accessor(m, uv, 5126, TINYGLTF_TYPE_VEC2, g.uv.size() / 2);
  }
  const int iv = add_view(m, g.idx.data(), g.idx.size() * 4, 34963);
  p.indices = add_accessor(m, iv, 5125, TINYGLTF_TYPE_SCALAR, g.idx.size());
  return p;
}

/// Adds a material whose base colour is an image: embedded PNG bytes (uri empty) or an external URI.
inline int add_textured_material(tinygltf::Model& m, const std::vector<uint8_t>& png, const std::string& uri = "") {
  tinygltf::Image img;
  if (uri.empty()) {
    img.bufferView = add_view(m, png.data(), png.size());
    img.mimeType = "image/png";
  } else {
    img.uri = uri;
  }
  m.images.push_back(img);
  if (m.samplers.empty()) m.samplers.emplace_back();
  tinygltf::Texture t;
  t.source = static_cast<int>(m.images.size()) - 1;
  t.sampler = 0;
  m.textures.push_back(t);
  tinygltf::Material mat;
  mat.name = "mat" + std::to_string(m.materials.size());
  mat.pbrMetallicRoughness.baseColorTexture.index = static_cast<int>(m.textures.size()) - 1;
  m.materials.push_back(mat);
  return static_cast<int>(m.materials.size()) - 1;
}

/// A model with one mesh on one node (with a matrix and extras), ready for primitives.
inline tinygltf::Model base_model() {
  tinygltf::Model m;
  m.asset.version = "2.0";
  m.asset.generator = "texdefrag tests";
  m.meshes.emplace_back();
  tinygltf::Node n;
  n.mesh = 0;
  n.matrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 10, 20, 30, 1};
  tinygltf::Value::Object ex;
  ex["tile"] = tinygltf::Value(std::string("t1"));
  n.extras = tinygltf::Value(ex);
  m.nodes.push_back(n);
  tinygltf::Scene s;
  s.nodes = {0};
  m.scenes.push_back(s);
  m.defaultScene = 0;
  return m;
}

/// Writes a model as GLB (or .gltf JSON with embedded buffers when the path ends in .gltf).
inline void save(const tinygltf::Model& m, const std::string& path) {
  tinygltf::TinyGLTF w;
  // note: images keep their URI or buffer view as set; tinygltf must not write image files.
  w.SetImageWriter([](const std::string*, const std::string*, const tinygltf::Image*, bool, std::string*, void*) { return false; },
                   nullptr);
  std::ostringstream os;
  const bool glb = std::filesystem::path(path).extension() != ".gltf";
  ASSERT_TRUE(w.WriteGltfSceneToStream(&m, os, !glb, glb)) << path;
  put_file(path, os.str());
}

/// Draco-encodes positions + TEXCOORD_0 + faces of `g` (sequential or Edgebreaker, quantised or not).
inline std::vector<uint8_t> draco_bytes(const GridData& g, int position_bits, bool edgebreaker, int* pos_id, int* uv_id) {
  draco::Mesh mesh;
  const size_t n = g.pos.size() / 3;
  mesh.set_num_points(static_cast<uint32_t>(n));
  for (size_t f = 0; f < g.idx.size(); f += 3)
    mesh.AddFace({draco::PointIndex(g.idx[f]), draco::PointIndex(g.idx[f + 1]), draco::PointIndex(g.idx[f + 2])});
  draco::GeometryAttribute pa, ta;
  pa.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 12, 0);
  ta.Init(draco::GeometryAttribute::TEX_COORD, nullptr, 2, draco::DT_FLOAT32, false, 8, 0);
  const int p = mesh.AddAttribute(pa, true, static_cast<uint32_t>(n));
  const int t = mesh.AddAttribute(ta, true, static_cast<uint32_t>(n));
  for (size_t i = 0; i < n; ++i) {
    mesh.attribute(p)->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), &g.pos[i * 3]);
    mesh.attribute(t)->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), &g.uv[i * 2]);
  }
  *pos_id = static_cast<int>(mesh.attribute(p)->unique_id());
  *uv_id = static_cast<int>(mesh.attribute(t)->unique_id());
  draco::Encoder enc;
  if (position_bits > 0) enc.SetAttributeQuantization(draco::GeometryAttribute::POSITION, position_bits);
  enc.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, 12);
  enc.SetEncodingMethod(edgebreaker ? draco::MESH_EDGEBREAKER_ENCODING : draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer buf;
  EXPECT_TRUE(enc.EncodeMeshToBuffer(mesh, &buf).ok());
  return std::vector<uint8_t>(buf.data(), buf.data() + buf.size());
}

/// A model whose one primitive is grid `g` (nx x ny quads, from grid(nx, ny)) Draco-compressed with
/// 14-bit positions (sequential or Edgebreaker connectivity) and a textured material whose page is
/// page_side^2 texels.
inline tinygltf::Model draco_grid_model(const std::string& dir, const GridData& g, int nx, int ny, int page_side,
                                        bool edgebreaker) {
  tinygltf::Model m = base_model();
  int pid = 0, tid = 0;
  const std::vector<uint8_t> d = draco_bytes(g, 14, edgebreaker, &pid, &tid);
  const int mat = add_textured_material(m, png_bytes(dir, page_side, page_side));
  const int dv = add_view(m, d.data(), d.size());
  tinygltf::Primitive p;
  p.mode = 4;
  p.material = mat;
  p.attributes["POSITION"] = add_accessor(m, -1, 5126, TINYGLTF_TYPE_VEC3, g.pos.size() / 3, {0, 0, 0},
                                          {static_cast<double>(nx), static_cast<double>(ny), 0});
  p.attributes["TEXCOORD_0"] = add_accessor(m, -1, 5126, TINYGLTF_TYPE_VEC2, g.uv.size() / 2);
  p.indices = add_accessor(m, -1, 5125, TINYGLTF_TYPE_SCALAR, g.idx.size());
  tinygltf::Value::Object attrs, ext;
  attrs["POSITION"] = tinygltf::Value(pid);
  attrs["TEXCOORD_0"] = tinygltf::Value(tid);
  ext["bufferView"] = tinygltf::Value(dv);
  ext["attributes"] = tinygltf::Value(attrs);
  p.extensions["KHR_draco_mesh_compression"] = tinygltf::Value(ext);
  m.meshes[0].primitives.push_back(p);
  m.extensionsUsed = {"KHR_draco_mesh_compression"};
  m.extensionsRequired = {"KHR_draco_mesh_compression"};
  return m;
}

/// The Khronos validator on `files`: "" when every file has 0 errors, "skip" when it is not
/// installed, else its output.
inline std::string validator_errors(const std::vector<std::string>& files) {
  const std::string script = std::string(::texdefrag::source_dir()) + "/scripts/validate-gltf.js";
  if (!std::filesystem::exists(std::string(::texdefrag::source_dir()) + "/tools/node/node_modules/gltf-validator")) return "skip";
  std::string cmd = "node '" + script + "'";
  for (const auto& f : files) cmd += " '" + f + "'";
  cmd += " 2>&1";
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return "cannot run node";
  char buf[4096];
  while (fgets(buf, sizeof buf, p)) out += buf;
  const int rc = pclose(p);
  return rc == 0 ? std::string() : out;
}

/// Skips the test's validator part with a message when gltf-validator is not installed.
#define TEXDEFRAG_EXPECT_VALID_GLTF(files)                                                              \
  do {                                                                                                 \
    const std::string v_ = ::texdefrag::gltf_test::validator_errors(files);                            \
    if (v_ == "skip")                                                                                  \
      std::printf("[  SKIPPED ] glTF validator: tools/node/node_modules absent (run scripts/install-npm.sh)\n"); \
    else                                                                                               \
      EXPECT_EQ(v_, "") << "Khronos glTF validator reported errors";                                  \
  } while (0)

}  // namespace texdefrag::gltf_test
