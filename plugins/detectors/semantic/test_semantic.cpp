// detectors.semantic on a hand-built scene (ground, a box building, a tree-like blob, a car-sized
// box) whose classes are known by construction, and on synthetic buildings with class truth.
#include "common/test_meshes.h"
#include "semantic/classify.h"
#include "texdefrag/synth/synth.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <set>

using namespace texdefrag;
using namespace texdefrag::detectors;
namespace tmesh = texdefrag::detectors::testmesh;
using semantic::FaceClass;

namespace {

enum Truth { kGround = 0, kVegetation = 1, kBuilding = 2, kOther = 3 };

/// Axis-aligned box (no bottom) from lo to hi, quads of about `step` metres.
void add_box(tmesh::Builder& b, const Vec3& lo, const Vec3& hi, double step, int& chart, int truth) {
  const Vec3 d = hi - lo;
  auto n = [step](double len) { return std::max(1, static_cast<int>(std::lround(len / step))); };
  const Vec3 X(d.x(), 0, 0), Y(0, d.y(), 0), Z(0, 0, d.z());
  chart = b.add_grid(lo, X, Z, n(d.x()), n(d.z()), 2, 2, chart, truth);
  chart = b.add_grid(lo + X, Y, Z, n(d.y()), n(d.z()), 2, 2, chart, truth);
  chart = b.add_grid(lo + X + Y, -X, Z, n(d.x()), n(d.z()), 2, 2, chart, truth);
  chart = b.add_grid(lo + Y, -Y, Z, n(d.y()), n(d.z()), 2, 2, chart, truth);
  chart = b.add_grid(lo + Z, X, Y, n(d.x()), n(d.y()), 2, 2, chart, truth);
}

/// A tree crown as photogrammetry sees it: a sphere of radius r whose vertices are displaced radially
/// by up to +-35% at random (leaves: rough at the scale of single faces), outward triangles.
void add_blob(tmesh::Builder& b, const Vec3& c, double r, int& chart, int truth) {
  const int nu = 24, nv = 12;
  auto p = [&](int i, int j) {
    const double th = 2 * M_PI * i / nu, ph = M_PI * j / nv;
    const unsigned h = (static_cast<unsigned>(i % nu) * 73856093u) ^ (static_cast<unsigned>(j) * 19349663u);
    const double bump = (j == 0 || j == nv) ? 1.0 : 1.0 + 0.35 * (static_cast<double>((h * 2654435761u) >> 8 & 0xffff) / 32767.5 - 1.0);
    return Vec3(c + r * bump * Vec3(std::sin(ph) * std::cos(th), std::sin(ph) * std::sin(th), std::cos(ph)));
  };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int ch = chart + (j / 2) * nu + i / 2;
      if (j > 0) b.add(p(i, j), p(i, j + 1), p(i + 1, j), ch, truth);
      if (j < nv - 1) b.add(p(i + 1, j), p(i, j + 1), p(i + 1, j + 1), ch, truth);
    }
  chart += nv * nu;
}

tmesh::Case scene() {
  tmesh::Builder b(tmesh::hash_noise(0.02));
  int chart = 0;
  chart = b.add_grid(Vec3(-30, -30, 0), Vec3(60, 0, 0), Vec3(0, 60, 0), 30, 30, 2, 2, chart, kGround);
  add_box(b, Vec3(1, 1, 0), Vec3(13, 11, 9), 1.0, chart, kBuilding);      // a house, 12 x 10 x 9 m
  add_blob(b, Vec3(-15, -15, 6), 3.0, chart, kVegetation);                 // a tree crown
  add_box(b, Vec3(-20, 10, 0), Vec3(-16, 12, 1.5), 0.5, chart, kOther);    // a car
  return b.build("scene");
}

/// Fraction of faces of truth class t that got class t.
double recall(const tmesh::Case& c, const semantic::Classification& r, int t) {
  size_t n = 0, ok = 0;
  for (size_t f = 0; f < c.truth.size(); ++f)
    if (c.truth[f] == t) ++n, ok += static_cast<int>(r.face_class[f]) == t;
  return n ? static_cast<double>(ok) / static_cast<double>(n) : 1.0;
}

}  // namespace

TEST(DetectorsSemantic, HandBuiltSceneGetsItsClasses) {
  const tmesh::Case c = scene();
  const Topology topo = build_topology(c.mesh);
  const semantic::Classification r = semantic::classify_faces(c.mesh, topo, {});
  EXPECT_GT(recall(c, r, kGround), 0.97);
  EXPECT_GT(recall(c, r, kBuilding), 0.97);
  EXPECT_GT(recall(c, r, kVegetation), 0.90);
  // The car is too low for a building; its edges are creases within a few faces, so part of it
  // looks rough (vegetation): the measured recall is 0.70, never building.
  EXPECT_GT(recall(c, r, kOther), 0.6);
  for (size_t f = 0; f < c.truth.size(); ++f)
    if (c.truth[f] == kOther) {
      EXPECT_NE(r.face_class[f], FaceClass::Building) << "face " << f;
    }
  EXPECT_EQ(r.building_components, 1);
}

TEST(DetectorsSemantic, RegionsNeverMixClassesAndReportNamesThem) {
  const tmesh::Case c = scene();
  const tmesh::Detection d = tmesh::run_detector("detectors.semantic", c.mesh);
  ASSERT_EQ(d.regions.face_region.size(), c.mesh.faces.size());
  const json& rc = d.report.at("region_class");
  ASSERT_EQ(rc.size(), static_cast<size_t>(d.regions.num_regions));
  // Every region holds one class; with `regions: classes` there is one region per class present.
  std::vector<std::set<int>> truths(static_cast<size_t>(d.regions.num_regions));
  for (size_t f = 0; f < c.truth.size(); ++f) truths[static_cast<size_t>(d.regions.face_region[f])].insert(c.truth[f]);
  int mixed = 0;
  for (const auto& t : truths) mixed += t.size() > 1;
  EXPECT_EQ(mixed, 0);
  EXPECT_EQ(d.report.at("class_faces").at("building").get<size_t>() > 0, true);
  const tmesh::Detection k = tmesh::run_detector("detectors.semantic", c.mesh, {{"regions", "classes"}});
  EXPECT_EQ(k.regions.num_regions, 4);
}

TEST(DetectorsSemantic, UpAxisYFindsTheSameClassesOnARotatedScene) {
  tmesh::Case c = scene();
  const Topology topo0 = build_topology(c.mesh);
  const semantic::Classification z = semantic::classify_faces(c.mesh, topo0, {});
  for (Vec3& p : c.mesh.positions) p = Vec3(p.x(), p.z(), -p.y());  // z-up -> y-up
  const Topology topo = build_topology(c.mesh);
  semantic::ClassifyOptions o;
  o.up = Vec3::UnitY();
  const semantic::Classification y = semantic::classify_faces(c.mesh, topo, o);
  size_t same = 0;
  for (size_t f = 0; f < z.face_class.size(); ++f) same += z.face_class[f] == y.face_class[f];
  EXPECT_GT(static_cast<double>(same) / static_cast<double>(z.face_class.size()), 0.99);
}

TEST(DetectorsSemantic, SyntheticBuildingsSeparateGroundFromBuilding) {
  for (const synth::Archetype a : {synth::Archetype::Residential, synth::Archetype::Factory, synth::Archetype::Hotel}) {
    synth::SynthOptions o;
    o.archetype = a;
    o.seed = 5;
    o.target_faces = 4000;
    o.noise_cm = 5;
    o.render_pages = false;
    const synth::SynthModel m = synth::generate(o);
    const Topology topo = build_topology(m.mesh);
    const semantic::Classification r = semantic::classify_faces(m.mesh, topo, {});
    size_t g = 0, g_ok = 0, b = 0, b_ok = 0;
    std::array<size_t, semantic::kNumClasses> missed{};
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      const bool wall_roof = m.truth.face_class[f] == synth::SemanticClass::Wall || m.truth.face_class[f] == synth::SemanticClass::Roof;
      if (wall_roof && r.face_class[f] != FaceClass::Building) ++missed[static_cast<size_t>(r.face_class[f])];
      if (m.truth.face_class[f] == synth::SemanticClass::Ground) ++g, g_ok += r.face_class[f] == FaceClass::Ground;
      else if (m.truth.face_class[f] != synth::SemanticClass::Detail) ++b, b_ok += r.face_class[f] == FaceClass::Building;
    }
    const double gr = static_cast<double>(g_ok) / static_cast<double>(g), br = static_cast<double>(b_ok) / static_cast<double>(b);
    std::printf("%-12s ground recall %.3f, building (wall+roof) recall %.3f (missed as ground %zu, vegetation %zu, other %zu)\n",
                m.truth.archetype.c_str(), gr, br, missed[0], missed[1], missed[3]);
    EXPECT_GT(gr, 0.9) << m.truth.archetype;
    EXPECT_GT(br, 0.9) << m.truth.archetype;
  }
}

// The hard preset's trees (trunk + canopy of 80 planar facets, each a flat patch at the mesh's
// resolution) are smooth at the 2-ring scale, tall and large, like the blob-shaped crowns of
// ContextCapture's L18 tiles: the roughness rule cannot see them; the planar-fraction rule must.
// Before it, 2-30% of the tree faces were vegetation (the rest building).
TEST(DetectorsSemantic, HardPresetTreesAreVegetation) {
  for (const synth::Archetype a : {synth::Archetype::Residential, synth::Archetype::Factory, synth::Archetype::Hotel,
                                   synth::Archetype::LShape}) {
    synth::SynthOptions o;
    ASSERT_TRUE(synth::apply_preset("hard", o));
    o.archetype = a;
    o.seed = 7;
    o.target_faces = 8000;
    o.render_pages = false;
    const synth::SynthModel m = synth::generate(o);
    const Topology topo = build_topology(m.mesh);
    const semantic::Classification r = semantic::classify_faces(m.mesh, topo, {});
    size_t trees = 0, trees_ok = 0, walls = 0, walls_ok = 0;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      const synth::SemanticClass t = m.truth.face_class[f];
      if (t == synth::SemanticClass::Vegetation) ++trees, trees_ok += r.face_class[f] == FaceClass::Vegetation;
      if (t == synth::SemanticClass::Wall || t == synth::SemanticClass::Roof)
        ++walls, walls_ok += r.face_class[f] == FaceClass::Building;
    }
    ASSERT_GT(trees, 100u) << m.truth.archetype;
    const double tr = static_cast<double>(trees_ok) / static_cast<double>(trees);
    const double wr = static_cast<double>(walls_ok) / static_cast<double>(walls);
    std::printf("%-12s hard preset: tree recall %.3f, wall+roof recall %.3f\n", m.truth.archetype.c_str(), tr, wr);
    EXPECT_GT(tr, 0.85) << m.truth.archetype;
    EXPECT_GT(wr, 0.95) << m.truth.archetype;
  }
}
