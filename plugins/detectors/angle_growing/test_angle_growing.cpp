// Tests of detectors.angle_growing, the plain normal-angle baseline.
#include "common/accuracy.h"
#include "common/test_meshes.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

using namespace texdefrag;
using namespace texdefrag::detectors;
namespace tmesh = texdefrag::detectors::testmesh;

namespace {
constexpr const char* kAG = "detectors.angle_growing";

/// Two unit-quad grids at a right angle (wall y = 0 and floor z = 0) sharing their edge.
tmesh::Case right_angle() {
  tmesh::Builder b;
  const int next = b.add_grid(Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(0, 0, 3), 4, 3, 1, 1, 0, 0);
  b.add_grid(Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(0, -3, 0), 4, 3, 2, 2, next, 1);
  return b.build("right_angle");
}
}  // namespace

TEST(DetectorsAngleGrowing, DeclaresOptions) {
  Registry::instance().load_plugins();
  const StageInfo* info = Registry::instance().find(kAG);
  ASSERT_NE(info, nullptr);
  const Options o = default_options(*info);
  EXPECT_EQ(o.get_double("angle_threshold_deg"), 25);
  EXPECT_EQ(o.get_string("unit"), "faces");
  EXPECT_THROW(default_options(*info, {{"unit", "triangles"}}), std::invalid_argument);
}

TEST(DetectorsAngleGrowing, RightAngleGivesTwoExactRegionsInBothUnitModes) {
  const tmesh::Case c = right_angle();
  for (const char* unit : {"faces", "patches"}) {
    const tmesh::Detection d = tmesh::run_detector(kAG, c.mesh, {{"unit", unit}});
    EXPECT_EQ(d.regions.num_regions, 2) << unit;
    EXPECT_DOUBLE_EQ(score_segmentation(d.regions.face_region, c.truth).accuracy, 1.0) << unit;
    // Threshold above 90 degrees is not allowed, but 90 itself still separates (strictly less).
    const tmesh::Detection w = tmesh::run_detector(kAG, c.mesh, {{"unit", unit}, {"angle_threshold_deg", 90}});
    EXPECT_EQ(w.regions.num_regions, 2) << unit;
  }
}

TEST(DetectorsAngleGrowing, NeighbourReferenceLeaksThroughASmoothCornerRegionReferenceDoesNot) {
  const tmesh::Case c = tmesh::curved_case();
  const tmesh::Detection nb = tmesh::run_detector(kAG, c.mesh);
  const tmesh::Detection rg = tmesh::run_detector(kAG, c.mesh, {{"reference", "region"}});
  // Faces 0 and the first face of facade B (truth 1) are in one region with "neighbour".
  size_t b_face = 0;
  while (c.truth[b_face] != 1) ++b_face;
  EXPECT_EQ(nb.regions.face_region[0], nb.regions.face_region[b_face]);
  EXPECT_NE(rg.regions.face_region[0], rg.regions.face_region[b_face]);
  EXPECT_GE(score_segmentation(nb.regions.face_region, c.truth).under_segmented, 1);
}

TEST(DetectorsAngleGrowing, EveryTexturedFaceGetsARegion) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(3, 3, 128, "p.png");
  m.faces[0].page = kNoPage;
  const tmesh::Detection d = tmesh::run_detector(kAG, m);
  EXPECT_EQ(d.regions.face_region[0], -1);
  for (size_t f = 1; f < m.faces.size(); ++f) EXPECT_EQ(d.regions.face_region[f], 0);
  EXPECT_EQ(d.regions.num_regions, 1);
}
