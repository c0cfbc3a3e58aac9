// Plane-labelling accuracy of detectors.region_growing against angle growing on small synthetic
// buildings with ground-truth planes (eval/synth, docs/synth.md), at real-like vertex noise:
// 20 cm on ~0.5 m edges gives a median angle of 25-45 degrees between neighbouring face normals, as
// on the ContextCapture development tiles (30-38 degrees; docs/detectors.md).
#include "common/accuracy.h"
#include "common/test_meshes.h"
#include "texdefrag/synth/synth.h"

#include <gtest/gtest.h>

#include <map>

using namespace texdefrag;
using namespace texdefrag::detectors;
namespace tmesh = texdefrag::detectors::testmesh;

namespace {

struct Scores {
  double main = 0;            ///< accuracy on wall, roof and ground planes (detail faces not counted)
  int wall_roof_regions = 0;  ///< regions holding >= 20 wall faces and >= 20 roof faces
};

Scores score(const synth::SynthModel& m, const std::string& detector, const json& opts = json::object()) {
  const tmesh::Detection d = tmesh::run_detector(detector, m.mesh, opts);
  std::vector<int> truth = m.truth.face_plane;
  std::map<int, std::pair<int, int>> classes;
  for (size_t f = 0; f < truth.size(); ++f) {
    if (m.truth.face_class[f] == synth::SemanticClass::Detail) truth[f] = -1;
    auto& c = classes[d.regions.face_region[f]];
    c.first += m.truth.face_class[f] == synth::SemanticClass::Wall;
    c.second += m.truth.face_class[f] == synth::SemanticClass::Roof;
  }
  Scores s;
  s.main = score_segmentation(d.regions.face_region, truth).accuracy;
  for (const auto& [r, c] : classes) s.wall_roof_regions += c.first >= 20 && c.second >= 20;
  std::printf("%-12s %-26s %-40s main-plane accuracy %.3f, wall+roof regions %d\n", m.name.c_str(), detector.c_str(),
              opts.dump().c_str(), s.main, s.wall_roof_regions);
  return s;
}

synth::SynthModel building(synth::Archetype a, double noise_cm) {
  synth::SynthOptions o;
  o.archetype = a;
  o.seed = 3;
  o.target_faces = 3000;
  o.noise_cm = noise_cm;
  o.render_pages = false;
  return synth::generate(o);
}

const synth::Archetype kArchetypes[] = {synth::Archetype::Residential, synth::Archetype::Factory, synth::Archetype::Hotel};

}  // namespace

TEST(DetectorsRegionGrowingSynth, BeatsAngleGrowingAtRealLikeNoiseAndNeverJoinsWallAndRoof) {
  double rg = 0, ag = 0, raw = 0, nocop = 0;
  for (const synth::Archetype a : kArchetypes) {
    const synth::SynthModel m = building(a, 20);
    const Scores s = score(m, "detectors.region_growing");
    const Scores s_ag = score(m, "detectors.angle_growing");
    // note: the filter's ablation is measured without coplanar grouping, which repairs much of what
    // raw normals break (facade pieces split by noise are coplanar).
    const Scores s_nocop = score(m, "detectors.region_growing", {{"coplanar_grouping", false}});
    const Scores s_raw =
        score(m, "detectors.region_growing", {{"normal_smoothing_iterations", 0}, {"coplanar_grouping", false}});
    EXPECT_GE(s.main, 0.85) << m.name;
    EXPECT_GT(s.main, s_ag.main + 0.1) << m.name;
    EXPECT_EQ(s.wall_roof_regions, 0) << m.name;
    EXPECT_GE(s.main, s_nocop.main - 0.01) << m.name;  // grouping never costs main-plane accuracy here
    rg += s.main / 3, ag += s_ag.main / 3, raw += s_raw.main / 3, nocop += s_nocop.main / 3;
  }
  EXPECT_GT(rg, ag + 0.3);      // measured 0.96 vs 0.54
  EXPECT_GT(nocop, raw + 0.1);  // filtered normals: measured 0.965 vs 0.825 with raw covariance fits
}

TEST(DetectorsRegionGrowingSynth, FindsTheMainPlanesAtLowNoise) {
  // At 2 cm (a few degrees between neighbouring faces) face-based angle growing is nearly exact too;
  // region growing loses a little where it cuts curved silos and towers into planar pieces.
  for (const synth::Archetype a : kArchetypes) {
    const synth::SynthModel m = building(a, 2);
    const Scores s = score(m, "detectors.region_growing");
    EXPECT_GE(s.main, 0.9) << m.name;
    EXPECT_EQ(s.wall_roof_regions, 0) << m.name;
  }
}
