// texdefrag buildings: every face in exactly one part, corners bit-identical, buildings without
// ground, on a synthetic building whose classes are known.
#include "texdefrag/buildings/extract.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/synth/synth.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <unistd.h>

using namespace texdefrag;
namespace fs = std::filesystem;

namespace {

struct Tmp {
  fs::path dir;
  explicit Tmp(const std::string& name) : dir(fs::temp_directory_path() / ("texdefrag_buildings_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(dir);
    fs::create_directories(dir / "in");
  }
  ~Tmp() { fs::remove_all(dir); }
};

synth::SynthOptions small_building() {
  synth::SynthOptions o;
  o.archetype = synth::Archetype::Residential;
  o.seed = 11;
  o.target_faces = 3000;
  o.page_size = 256;
  o.texels_per_edge = 2;
  return o;
}

}  // namespace

TEST(Buildings, SubMeshKeepsCornersExactly) {
  synth::SynthOptions o = small_building();
  o.render_pages = false;
  const synth::SynthModel m = synth::generate(o);
  const std::vector<size_t> faces{3, 1, 2};
  const TexturedMesh s = buildings::sub_mesh(m.mesh, faces);
  ASSERT_EQ(s.faces.size(), 3u);
  for (size_t i = 0; i < faces.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(s.corner_position(i, c), m.mesh.corner_position(faces[i], c));
      EXPECT_EQ(s.texcoords[static_cast<size_t>(s.faces[i].vt[static_cast<size_t>(c)])],
                m.mesh.texcoords[static_cast<size_t>(m.mesh.faces[faces[i]].vt[static_cast<size_t>(c)])]);
    }
  EXPECT_LE(s.positions.size(), 9u);
}

TEST(Buildings, SyntheticBuildingIsCutFromItsGroundAndEveryFaceIsWrittenOnce) {
  Tmp tmp("synth");
  synth::SynthOptions o = small_building();
  synth::SynthModel m = synth::generate(o);
  synth::write_model(m, o, (tmp.dir / "in").string());
  const std::string obj = (tmp.dir / "in" / (m.name + ".obj")).string();
  const TexturedMesh mesh = read_obj(obj);
  const buildings::Extraction ex = buildings::extract_buildings(mesh, {});
  ASSERT_GE(ex.parts.size(), 2u);
  EXPECT_EQ(ex.parts.back().name, "rest");
  std::set<size_t> seen;
  for (const auto& p : ex.parts)
    for (size_t f : p.faces) EXPECT_TRUE(seen.insert(f).second) << "face " << f << " in two parts";
  EXPECT_EQ(seen.size(), mesh.faces.size());
  // The largest building holds most walls and roofs and almost no ground.
  size_t ground_in = 0, building_faces = 0, wall_roof = 0;
  for (size_t f : ex.parts[0].faces) ground_in += m.truth.face_class[f] == synth::SemanticClass::Ground;
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    building_faces += m.truth.face_class[f] == synth::SemanticClass::Wall || m.truth.face_class[f] == synth::SemanticClass::Roof;
  for (size_t f : ex.parts[0].faces)
    wall_roof += m.truth.face_class[f] == synth::SemanticClass::Wall || m.truth.face_class[f] == synth::SemanticClass::Roof;
  EXPECT_LT(static_cast<double>(ground_in), 0.02 * static_cast<double>(ex.parts[0].faces.size()));
  EXPECT_GT(static_cast<double>(wall_roof), 0.9 * static_cast<double>(building_faces));
  // Written and checked (write_parts reads every part back and matches each input face once).
  const json man = buildings::write_parts(mesh, obj, ex, (tmp.dir / "out").string());
  size_t written = 0;
  for (const auto& p : man["parts"]) {
    const TexturedMesh back = read_obj((tmp.dir / "out" / p["obj"].get<std::string>()).string());
    written += back.faces.size();
  }
  EXPECT_EQ(written, mesh.faces.size());
  EXPECT_THROW(buildings::write_parts(mesh, obj, ex, (tmp.dir / "in").string()), std::runtime_error);
}

TEST(Buildings, BadDetectorOptionNamesTheKey) {
  synth::SynthOptions o = small_building();
  o.render_pages = false;
  const synth::SynthModel m = synth::generate(o);
  buildings::ExtractOptions eo;
  eo.detector = {{"ground_cel", 2.0}};
  try {
    buildings::extract_buildings(m.mesh, eo);
    FAIL() << "accepted an unknown option";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("ground_cell"), std::string::npos) << e.what();
  }
}
