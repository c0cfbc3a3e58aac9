// Writes the seed corpora of the format fuzzers (fuzz_gltf, fuzz_osgb, fuzz_tiles3d) into
// OUT_DIR/{gltf,osgb,tiles3d}: tiny files built as the IO tests build theirs (tests/io/
// gltf_test_util.h: tinygltf's writer and Draco's encoder; the osg API for OSGB; write_b3dm), so
// no data file is kept in the repository. Every seed is under the fuzzers' -max_len (4096 bytes).
// Usage: make_fuzz_seeds OUT_DIR
#include "../io/gltf_test_util.h"
#include "texdefrag/io/tiles3d.h"

#include <osg/Geode>
#include <osg/Geometry>
#include <osg/PagedLOD>
#include <osg/Texture2D>
#include <osgDB/WriteFile>

#include <cstdio>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::gltf_test;

namespace {

std::string bytes_of(const std::string& path) {
  const std::vector<uint8_t> b = file_bytes(path);
  return std::string(b.begin(), b.end());
}

/// A GLB (or .gltf) of a textured n-by-n fragmented grid with an embedded 4x4 PNG page.
std::string grid_model(const std::string& dir, const std::string& name, int n, int mode = 4) {
  tinygltf::Model m = base_model();
  m.meshes[0].primitives.push_back(add_primitive(m, grid(n, n), add_textured_material(m, png_bytes(dir, 4, 4)), mode));
  save(m, dir + "/" + name);
  return dir + "/" + name;
}

/// A GLB whose primitive is Draco-compressed (sequential or Edgebreaker connectivity).
void draco_model(const std::string& dir, const std::string& name, bool edgebreaker) {
  save(draco_grid_model(dir, grid(2, 1), 2, 1, 4, edgebreaker), dir + "/" + name);
}

void gltf_seeds(const std::string& dir) {
  grid_model(dir, "grid.glb", 1);
  grid_model(dir, "strip.glb", 1, 5);
  grid_model(dir, "fan.glb", 1, 6);
  grid_model(dir, "grid.gltf", 1);  // JSON, buffers as data URIs
  draco_model(dir, "draco_sequential.glb", false);
  draco_model(dir, "draco_edgebreaker.glb", true);
}

/// A 4x4 RGB texture.
osg::ref_ptr<osg::Texture2D> texture(const std::string& name) {
  osg::ref_ptr<osg::Image> im = new osg::Image;
  im->allocateImage(4, 4, 1, GL_RGB, GL_UNSIGNED_BYTE);
  for (int i = 0; i < 48; ++i) im->data()[i] = static_cast<unsigned char>(i * 5);
  im->setFileName(name);
  return new osg::Texture2D(im.get());
}

/// A textured geometry of n vertices on two rows drawn by `set`.
template <class VecArray>
osg::ref_ptr<osg::Geometry> geometry(int n, osg::PrimitiveSet* set, osg::Texture2D* tex) {
  osg::ref_ptr<osg::Geometry> g = new osg::Geometry;
  osg::ref_ptr<VecArray> v = new VecArray;
  osg::ref_ptr<osg::Vec2Array> tc = new osg::Vec2Array;
  for (int i = 0; i < n; ++i) {
    v->push_back(typename VecArray::ElementDataType(i / 2, i % 2, 0));
    tc->push_back(osg::Vec2(0.1f + 0.2f * (i / 2), 0.1f + 0.5f * (i % 2)));
  }
  g->setVertexArray(v.get());
  g->setTexCoordArray(0, tc.get(), osg::Array::BIND_PER_VERTEX);
  g->addPrimitiveSet(set);
  osg::ref_ptr<osg::StateSet> ss = new osg::StateSet;
  ss->setTextureAttributeAndModes(0, tex, osg::StateAttribute::ON);
  g->setStateSet(ss.get());
  return g;
}

void osgb_seeds(const std::string& dir) {
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeData");
  osg::ref_ptr<osg::Texture2D> t = texture("t.png");
  osg::ref_ptr<osg::DrawElementsUShort> tris = new osg::DrawElementsUShort(GL_TRIANGLES);
  for (unsigned short i : {0, 2, 1, 1, 2, 3}) tris->push_back(i);
  osg::ref_ptr<osg::Geode> geode = new osg::Geode;
  geode->addDrawable(geometry<osg::Vec3Array>(4, tris.get(), t.get()).get());
  osgDB::writeNodeFile(*geode, dir + "/triangles.osgb", opt.get());

  osg::ref_ptr<osg::Geode> strips = new osg::Geode;
  strips->addDrawable(geometry<osg::Vec3dArray>(6, new osg::DrawArrays(GL_TRIANGLE_STRIP, 0, 6), t.get()).get());
  osg::ref_ptr<osg::DrawArrayLengths> lengths = new osg::DrawArrayLengths(GL_TRIANGLE_FAN, 0);
  lengths->push_back(3);
  lengths->push_back(3);
  strips->addDrawable(geometry<osg::Vec3Array>(6, lengths.get(), t.get()).get());
  osg::ref_ptr<osg::PagedLOD> lod = new osg::PagedLOD;
  lod->setCenterMode(osg::LOD::USER_DEFINED_CENTER);
  lod->setRadius(4);
  lod->addChild(strips.get(), 0, 10);
  lod->setFileName(1, "triangles.osgb");
  lod->setRange(1, 10, 1e30f);
  osgDB::writeNodeFile(*lod, dir + "/paged_lod.osgb", opt.get());
}

/// b3dm seeds and tileset JSON seeds. The tileset seeds name contents that fuzz_tiles3d's folder
/// holds (a.b3dm, b.glb, sub/ext.json -> sub/c.glb; see fuzz_tiles3d.cpp).
void tiles3d_seeds(const std::string& dir, const std::string& scratch) {
  B3dm b;
  b.feature_table_json = R"({"BATCH_LENGTH":0,"RTC_CENTER":[0,0,0]})";
  while ((28 + b.feature_table_json.size()) % 8) b.feature_table_json += ' ';
  b.batch_table_json = R"({"name":[]}   )";
  const std::string glb = bytes_of(grid_model(scratch, "b3dm.glb", 1));
  b.glb.assign(glb.begin(), glb.end());
  put_file(dir + "/a.b3dm", write_b3dm(b));
  const nlohmann::json box = {{"box", {1, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1}}};
  const nlohmann::json ts = {
      {"asset", {{"version", "1.0"}}},
      {"geometricError", 10},
      {"root",
       {{"boundingVolume", box},
        {"geometricError", 5},
        {"refine", "REPLACE"},
        {"transform", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 100, 200, 0, 1}},
        {"children",
         {{{"boundingVolume", box}, {"geometricError", 1}, {"content", {{"uri", "a.b3dm"}}}},
          {{"boundingVolume", box}, {"geometricError", 1}, {"content", {{"uri", "b.glb"}}}},
          {{"boundingVolume", box}, {"geometricError", 1}, {"contents", {{{"uri", "sub/ext.json"}}}}}}}}}};
  put_file(dir + "/tileset.json", ts.dump());
  const nlohmann::json region = {
      {"asset", {{"version", "1.1"}}},
      {"geometricError", 1},
      {"root", {{"boundingVolume", {{"region", {-1.3, 0.6, -1.29, 0.61, 0, 20}}}}, {"geometricError", 0}, {"content", {{"uri", "b.glb"}}}}}};
  put_file(dir + "/region.json", region.dump());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds OUT_DIR\n");
    return 2;
  }
  const std::string out = argv[1], scratch = out + "/scratch";
  for (const char* d : {"gltf", "osgb", "tiles3d", "scratch"}) {
    fs::remove_all(out + "/" + d);
    fs::create_directories(out + "/" + d);
  }
  gltf_seeds(out + "/gltf");
  osgb_seeds(out + "/osgb");
  tiles3d_seeds(out + "/tiles3d", scratch);
  fs::remove_all(scratch);
  for (const char* d : {"gltf", "osgb", "tiles3d"})
    for (const auto& e : fs::directory_iterator(out + "/" + d))
      if (e.file_size() > 4096) {
        std::fprintf(stderr, "make_fuzz_seeds: %s is %zu bytes, over the fuzzers' 4096\n", e.path().c_str(),
                     static_cast<size_t>(e.file_size()));
        return 1;
      }
  return 0;
}
