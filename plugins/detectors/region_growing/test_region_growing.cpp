// Tests of detectors.region_growing (Liu et al. 2024, section 2.1) and the shared plane-fit/CPI code.
#include "common/accuracy.h"
#include "common/normals.h"
#include "common/planarity.h"
#include "common/test_meshes.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

using namespace texdefrag;
using namespace texdefrag::detectors;
namespace tmesh = texdefrag::detectors::testmesh;

namespace {

constexpr const char* kRG = "detectors.region_growing";
constexpr const char* kAG = "detectors.angle_growing";

SegmentationScore score(const tmesh::Case& c, const std::string& name, const json& opts = json::object(),
                        json* report = nullptr) {
  const tmesh::Detection d = tmesh::run_detector(name, c.mesh, opts);
  if (report) *report = d.report;
  const SegmentationScore s = score_segmentation(d.regions.face_region, c.truth);
  std::printf("%-14s %-26s %-50s accuracy %.3f regions %d (truth %d) over %d under %d\n", c.name.c_str(),
              name.c_str(), opts.dump().c_str(), s.accuracy, s.regions, s.truth_planes, s.over_segmented,
              s.under_segmented);
  return s;
}

void expect_valid(const TexturedMesh& m, const Regions& r) {
  ASSERT_EQ(r.face_region.size(), m.faces.size());
  std::vector<int> used(static_cast<size_t>(r.num_regions), 0);
  for (size_t f = 0; f < m.faces.size(); ++f) {
    if (m.faces[f].page == kNoPage) {
      EXPECT_EQ(r.face_region[f], -1);
    } else {
      ASSERT_GE(r.face_region[f], 0);
      ASSERT_LT(r.face_region[f], r.num_regions);
      used[static_cast<size_t>(r.face_region[f])] = 1;
    }
  }
  for (int u : used) EXPECT_EQ(u, 1) << "empty region id";
}

}  // namespace

TEST(DetectorsPlanarity, CpiTermsFollowTheirDefinitions) {
  EXPECT_DOUBLE_EQ(flatness_term(0, 2), 1.0);
  EXPECT_DOUBLE_EQ(flatness_term(1, 4), 0.75);
  EXPECT_DOUBLE_EQ(flatness_term(3, 3), 0.0);
  EXPECT_DOUBLE_EQ(flatness_term(0, 0), 0.0);  // no plane through a point or a segment
  EXPECT_DOUBLE_EQ(compactness_term(1, 4), 0.25);
  EXPECT_DOUBLE_EQ(compactness_term(2, 2), 1.0);
  EXPECT_DOUBLE_EQ(compactness_term(0, 0), 0.0);
  EXPECT_DOUBLE_EQ(normal_consistency_term(0), 1.0);
  EXPECT_NEAR(normal_consistency_term(M_PI / 6), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(normal_consistency_term(M_PI), 0.0);  // facing away is not "consistent again"
  PlaneFit f;
  f.valid = true;
  f.eigenvalues = Vec3(0, 1, 4);
  EXPECT_NEAR(planarity_index(f, M_PI / 6, CpiWeights{}), 0.4 * 1 + 0.3 * 0.25 + 0.3 * 0.5, 1e-12);
  EXPECT_NEAR(planarity_index(f, 0, CpiWeights{1, 0, 0}), 1.0, 1e-12);
  f.valid = false;
  EXPECT_EQ(planarity_index(f, 0, CpiWeights{}), 0.0);
}

TEST(DetectorsPlanarity, FitOfRectangleHasExactEigenvaluesAndOrientedNormal) {
  // 2 x 1 rectangle in the plane z = 3, counter-clockwise seen from +z: uniform area covariance
  // has variances 2^2/12 and 1^2/12 and 0 across.
  PlaneMoments m;
  const Vec3 a(0, 0, 3), b(2, 0, 3), c(2, 1, 3), d(0, 1, 3);
  m.add_triangle(a, b, c);
  m.add_triangle(a, c, d);
  const PlaneFit f = fit_plane(m);
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.eigenvalues[0], 0.0, 1e-12);
  EXPECT_NEAR(f.eigenvalues[1], 1.0 / 12, 1e-12);
  EXPECT_NEAR(f.eigenvalues[2], 4.0 / 12, 1e-12);
  EXPECT_NEAR(f.normal.z(), 1.0, 1e-12);
  EXPECT_NEAR((f.centroid - Vec3(1, 0.5, 3)).norm(), 0.0, 1e-12);
  PlaneMoments flipped;
  flipped.add_triangle(a, c, b);
  flipped.add_triangle(a, d, c);
  EXPECT_NEAR(fit_plane(flipped).normal.z(), -1.0, 1e-12);
  EXPECT_NEAR(normal_angle(Vec3::UnitZ(), -Vec3::UnitZ()), M_PI, 1e-12);
  EXPECT_FALSE(fit_plane(PlaneMoments{}).valid);
}

TEST(DetectorsPlanarity, PlaneRmsDistanceFromMoments) {
  // Unit square in z = 0: distance to z = 0.5 is 0.5 everywhere; to the plane x = 0 the RMS of x
  // over [0, 1] is sqrt(1/3).
  PlaneMoments m;
  m.add_triangle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0));
  m.add_triangle(Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
  EXPECT_NEAR(plane_rms_distance(m, Vec3(3, -2, 0.5), Vec3::UnitZ()), 0.5, 1e-12);
  EXPECT_NEAR(plane_rms_distance(m, Vec3(0, 0, 0), Vec3::UnitZ()), 0.0, 1e-9);
  EXPECT_NEAR(plane_rms_distance(m, Vec3(0, 5, 7), Vec3::UnitX()), std::sqrt(1.0 / 3), 1e-12);
  EXPECT_EQ(plane_rms_distance(PlaneMoments{}, Vec3::Zero(), Vec3::UnitZ()), 0.0);
}

TEST(DetectorsNormals, BilateralFilterSmoothsNoiseAndKeepsACrease) {
  // A noisy wall (y = 0, normal -y) and roof (z = 8, normal +z) meeting at a right angle.
  const tmesh::Case c = tmesh::jagged_case();
  const Topology topo = build_topology(c.mesh);
  const std::vector<Vec3> raw = filter_face_normals(c.mesh, topo, 0, M_PI / 6);
  const std::vector<Vec3> smooth = filter_face_normals(c.mesh, topo, 5, M_PI / 6);
  ASSERT_EQ(smooth.size(), c.mesh.faces.size());
  double err_raw = 0, err_smooth = 0, worst = 0;
  for (size_t f = 0; f < raw.size(); ++f) {
    const Vec3 truth = c.truth[f] == 0 ? Vec3(0, -1, 0) : Vec3(0, 0, 1);
    EXPECT_NEAR(smooth[f].norm(), 1.0, 1e-12);
    EXPECT_NEAR(raw[f].dot(face_normal(c.mesh, f)), 1.0, 1e-12);  // 0 passes = the raw normals
    err_raw += normal_angle(raw[f], truth);
    err_smooth += normal_angle(smooth[f], truth);
    worst = std::max(worst, normal_angle(smooth[f], truth));
  }
  EXPECT_LT(err_smooth, 0.5 * err_raw);  // noise averaged out...
  EXPECT_LT(worst, 30 * M_PI / 180);     // ...and no face next to the crease is pulled to 45 degrees
  EXPECT_GT(mean_edge_length(c.mesh, topo), 0.9);
  EXPECT_LT(mean_edge_length(c.mesh, topo), 1.4);  // 1 m quads: sides 1, diagonals 1.41
}

TEST(DetectorsRegionGrowing, JaggedRefinementJoinsTheFittingPlaneNotTheLargerOne) {
  // A wall (12 x 8 quads) and a roof (12 x 4 quads) at a right angle, every chart 2 x 2 quads
  // (8 faces). Growth is switched off (all CPI weights 0: no unit passes), so the jagged refinement
  // alone groups the charts. Regions join the neighbour whose plane they fit, so roof charts on the
  // crease go to the roof although the wall has more faces, and the last wall and roof groups fit
  // nothing and stay apart. The paper's size-only rule (any angle, any distance) merges the two.
  tmesh::Builder b;
  const int next = b.add_grid(Vec3(0, 0, 0), Vec3(12, 0, 0), Vec3(0, 0, 8), 12, 8, 2, 2, 0, 0);
  b.add_grid(Vec3(0, 0, 8), Vec3(12, 0, 0), Vec3(0, 4, 0), 12, 4, 2, 2, next, 1);
  const tmesh::Case c = b.build("wall_roof_charts");
  const json only_jagged = {{"w_flatness", 0}, {"w_compactness", 0}, {"w_normal", 0}, {"curved_components", false},
                            {"elongated_strips", false}, {"min_region_faces", 100000}};
  json rep;
  const auto plane = score(c, kRG, only_jagged, &rep);
  EXPECT_EQ(rep["grown_regions"], 36);  // 24 wall + 12 roof charts, none joined by growth
  EXPECT_EQ(plane.regions, 2);
  EXPECT_DOUBLE_EQ(plane.accuracy, 1.0);
  EXPECT_EQ(rep["jagged_small_regions_kept"], 2);  // the final wall and roof groups
  json size_only = only_jagged;
  size_only["angle_threshold_deg"] = 90;
  size_only["max_plane_distance"] = 1000;
  const auto by_size = score(c, kRG, size_only);
  EXPECT_EQ(by_size.regions, 1);
  EXPECT_EQ(by_size.under_segmented, 1);
}

TEST(DetectorsRegionGrowing, SmallRoofPieceOnAWallStaysAloneUnlessTiny) {
  // A wall of 2x2-quad charts with a 1-quad-deep canopy (2 x 1 quads = 4 faces, one chart) sticking
  // out at a right angle: the canopy fits no neighbour's plane and stays its own region; with
  // tiny_region_faces >= 4 it joins the wall (the size-only rule for very small regions).
  tmesh::Builder b;
  const int next = b.add_grid(Vec3(0, 0, 0), Vec3(8, 0, 0), Vec3(0, 0, 6), 8, 6, 2, 2, 0, 0);
  b.add_grid(Vec3(3, -1, 4), Vec3(2, 0, 0), Vec3(0, 1, 0), 2, 1, 2, 1, next, 1);
  const tmesh::Case c = b.build("canopy");
  json rep;
  const auto kept = score(c, kRG, json::object(), &rep);
  EXPECT_EQ(kept.regions, 2);
  EXPECT_DOUBLE_EQ(kept.accuracy, 1.0);
  const auto tiny = score(c, kRG, {{"tiny_region_faces", 4}});
  EXPECT_EQ(tiny.regions, 1);
}

namespace {

/// Adds a wedge closing the hole x in [x0, x0 + 2], z in [2, 3] of a wall at y = 0 whose faces point
/// to -y: it sticks out 1 m at the bottom (z = 2; a sloped sill) or at the top (z = 3). Faces: the
/// 45-degree panel (4 triangles), the horizontal face (4) and the two vertical end triangles (2),
/// all in chart `chart`, truth `truth`, pointing away from the wedge's inside. Wall-side edges are
/// split at x0 + 1 like the wall's 1 m grid, so every border edge is a welded wall edge.
void add_wedge(tmesh::Builder& b, double x0, bool out_at_top, int chart, int truth) {
  const double zo = out_at_top ? 3 : 2;  // height of the outer edge
  const Vec3 inside(x0 + 1, -0.3, out_at_top ? 2.7 : 2.3);
  auto tri = [&](const Vec3& p, const Vec3& q, const Vec3& r) {
    if ((q - p).cross(r - p).dot((p + q + r) / 3 - inside) > 0) b.add(p, q, r, chart, truth);
    else b.add(p, r, q, chart, truth);
  };
  auto strip = [&](double y0, double z0, double y1, double z1) {  // x0..x0+2, two 1 m quads
    for (int i = 0; i < 2; ++i) {
      const double xa = x0 + i, xb = x0 + i + 1;
      tri(Vec3(xa, y0, z0), Vec3(xb, y0, z0), Vec3(xb, y1, z1));
      tri(Vec3(xa, y0, z0), Vec3(xb, y1, z1), Vec3(xa, y1, z1));
    }
  };
  const double zi = out_at_top ? 2 : 3;  // wall edge the panel starts from
  strip(-1, zo, 0, zi);  // panel
  strip(0, zo, -1, zo);  // horizontal face
  for (const double x : {x0, x0 + 2}) tri(Vec3(x, 0, 2), Vec3(x, 0, 3), Vec3(x, -1, zo));
}

/// Wall y = 0, x in [0, 10], z in [0, 8], 1 m quads in 2x2-quad charts, with the hole x in
/// [3, 3 + hole_width], z in [2, 3] left open. Returns the next free chart id.
int add_wall_with_hole(tmesh::Builder& b, int hole_width) {
  int next = b.add_grid(Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(0, 0, 2), 10, 2, 2, 2, 0, 0);
  next = b.add_grid(Vec3(0, 0, 2), Vec3(3, 0, 0), Vec3(0, 0, 1), 3, 1, 2, 2, next, 0);
  const int right = 3 + hole_width;
  next = b.add_grid(Vec3(right, 0, 2), Vec3(10 - right, 0, 0), Vec3(0, 0, 1), 10 - right, 1, 2, 2, next, 0);
  return b.add_grid(Vec3(0, 0, 3), Vec3(10, 0, 0), Vec3(0, 0, 5), 10, 5, 2, 2, next, 0);
}

// Options isolating the enclosed rule: wedges stay one unit (no split), units are judged by their
// covariance fit (tilted ~45 degrees, so growth never takes a wedge into the wall), jagged and
// coplanar grouping off (its speckle step would take the wedge first: it lies within half an edge of
// the wall's plane).
const json kEnclosedIso = {{"split_nonplanar_patches", false}, {"fit_min_faces", 1}, {"jagged_borders", false},
                           {"coplanar_grouping", false}};

/// Wall y = 0 of 1 m quads in 2x2-quad charts, x in [0, 21], z in [0, 4], cut at x in [10, 11] by
/// a vertical ridge sticking out `depth` m towards -y (two panels of 4 quads each, one chart per
/// panel, tilted atan(depth / 0.5) from the wall). The two wall pieces touch only the ridge.
/// Truth: left piece 0, right piece 1, ridge panels 2 and 3.
tmesh::Case ridge_wall(double depth) {
  tmesh::Builder b;
  int next = b.add_grid(Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(0, 0, 4), 10, 4, 2, 2, 0, 0);
  next = b.add_grid(Vec3(11, 0, 0), Vec3(10, 0, 0), Vec3(0, 0, 4), 10, 4, 2, 2, next, 1);
  next = b.add_grid(Vec3(10, 0, 0), Vec3(0.5, -depth, 0), Vec3(0, 0, 4), 1, 4, 1, 4, next, 2);
  b.add_grid(Vec3(10.5, -depth, 0), Vec3(0.5, depth, 0), Vec3(0, 0, 4), 1, 4, 1, 4, next, 3);
  return b.build("ridge_wall");
}

/// Wall y = 0, x in [0, 10], z in [0, 8], 0.5 m quads in 2x2-quad charts, with a 2 x 2 m window
/// (x in [4, 6], z in [3, 5]) recessed `depth` m behind it (towards +y: the wall faces -y), joined
/// by four reveal strips. Truth: wall 0, window plane 1, reveals 2.
tmesh::Case recessed_window(double depth) {
  tmesh::Builder b;
  int next = 0;
  // Wall around the hole: below, above, left, right.
  next = b.add_grid(Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(0, 0, 3), 20, 6, 2, 2, next, 0);
  next = b.add_grid(Vec3(0, 0, 5), Vec3(10, 0, 0), Vec3(0, 0, 3), 20, 6, 2, 2, next, 0);
  next = b.add_grid(Vec3(0, 0, 3), Vec3(4, 0, 0), Vec3(0, 0, 2), 8, 4, 2, 2, next, 0);
  next = b.add_grid(Vec3(6, 0, 3), Vec3(4, 0, 0), Vec3(0, 0, 2), 8, 4, 2, 2, next, 0);
  next = b.add_grid(Vec3(4, depth, 3), Vec3(2, 0, 0), Vec3(0, 0, 2), 4, 4, 2, 2, next, 1);
  // Reveals (normals pointing into the opening): bottom, top, left, right.
  next = b.add_grid(Vec3(4, 0, 3), Vec3(2, 0, 0), Vec3(0, depth, 0), 4, 1, 4, 1, next, 2);
  next = b.add_grid(Vec3(4, depth, 5), Vec3(2, 0, 0), Vec3(0, -depth, 0), 4, 1, 4, 1, next, 2);
  next = b.add_grid(Vec3(4, 0, 3), Vec3(0, depth, 0), Vec3(0, 0, 2), 1, 4, 1, 4, next, 2);
  b.add_grid(Vec3(6, depth, 3), Vec3(0, -depth, 0), Vec3(0, 0, 2), 1, 4, 1, 4, next, 2);
  return b.build("recessed_window");
}

/// A closed cylinder (silo wall) of radius 5 m and height 8 m in 48 segments (7.5 degrees, 0.65 m)
/// of 1 m rows, in charts of 2 x 2 quads, with vertex noise `noise` m; beside it, not touching, a
/// 10 x 8 m flat wall. Truth: silo 0, wall 1.
tmesh::Case silo(double noise) {
  tmesh::Builder b(noise > 0 ? tmesh::hash_noise(noise, 7) : std::function<Vec3(const Vec3&)>{});
  const int seg = 48, rows = 8;
  const double R = 5;
  auto P = [&](int s, int k) {
    const double phi = 2 * M_PI * (s % seg) / seg;
    return Vec3(R * std::cos(phi), R * std::sin(phi), k);
  };
  for (int s = 0; s < seg; ++s)
    for (int k = 0; k < rows; ++k) {
      const int chart = (k / 2) * (seg / 2) + s / 2;
      b.add(P(s, k), P(s + 1, k), P(s + 1, k + 1), chart, 0);
      b.add(P(s, k), P(s + 1, k + 1), P(s, k + 1), chart, 0);
    }
  b.add_grid(Vec3(10, -5, 0), Vec3(0, 10, 0), Vec3(0, 0, 8), 10, 8, 2, 2, 1000, 1);
  return b.build("silo");
}

/// Region of the first face with truth id t.
int region_of_truth(const tmesh::Case& c, const Regions& r, int t) {
  for (size_t f = 0; f < c.truth.size(); ++f)
    if (c.truth[f] == t) return r.face_region[f];
  return -2;
}

}  // namespace

TEST(DetectorsRegionGrowing, EnclosedTiltedBumpJoinsItsWall) {
  // A 10 x 8 m wall (156 faces) with a 2 x 1 m hole closed by a wedge sticking out 1 m (10 faces).
  // Every border edge of the wedge is a wall edge (fully enclosed) and 10 < 0.1 * 156.
  tmesh::Builder b;
  add_wedge(b, 3, false, add_wall_with_hole(b, 2), 1);
  const tmesh::Case c = b.build("enclosed_bump");
  ASSERT_EQ(c.mesh.faces.size(), 166u);
  json off_opts = kEnclosedIso, small_opts = kEnclosedIso;
  off_opts["absorb_enclosed"] = false;
  small_opts["enclosed_max_fraction"] = 0.05;  // 10 faces is not under 0.05 * 156 = 7.8
  const auto off = score(c, kRG, off_opts);
  EXPECT_EQ(off.regions, 2);
  EXPECT_DOUBLE_EQ(off.accuracy, 1.0);
  EXPECT_EQ(score(c, kRG, small_opts).regions, 2);
  json rep;
  const auto on = score(c, kRG, kEnclosedIso, &rep);
  EXPECT_EQ(on.regions, 1);
  EXPECT_EQ(rep["enclosed_regions_absorbed"], 1);
  EXPECT_EQ(rep["enclosed_faces_moved"], 10);
  // With all defaults the wedge ends up in the wall too.
  EXPECT_EQ(score(c, kRG).regions, 1);
}

TEST(DetectorsRegionGrowing, EnclosedClusterOfTwoRegionsJoinsItsWall) {
  // The same wall with a 4 x 1 m hole (152 faces) closed by two wedges meeting at x = 5: wedge 1
  // sticks out at the bottom, wedge 2 at the top (panels 90 degrees apart: they never grow
  // together); each has its own end triangle at x = 5 and the two share only the edge
  // (5,0,2)-(5,0,3). Border of each: 5 m wall, 1 m the other wedge: 5/6 < 0.9 (set here; the default
  // is 0.75), not enclosed alone;
  // together: 10 m, all wall: enclosed. 20 faces < 0.2 * 152.
  tmesh::Builder b;
  const int next = add_wall_with_hole(b, 4);
  add_wedge(b, 3, false, next, 1);
  add_wedge(b, 5, true, next + 1, 2);
  const tmesh::Case c = b.build("enclosed_cluster");
  ASSERT_EQ(c.mesh.faces.size(), 172u);
  json on_opts = kEnclosedIso;
  on_opts["enclosed_max_fraction"] = 0.2;
  on_opts["enclosed_border_fraction"] = 0.9;  // 5/6 of each wedge's border is wall: alone, not enclosed
  json off_opts = on_opts;
  off_opts["absorb_enclosed"] = false;
  const auto off = score(c, kRG, off_opts);
  EXPECT_EQ(off.regions, 3);
  EXPECT_DOUBLE_EQ(off.accuracy, 1.0);
  json rep;
  const auto on = score(c, kRG, on_opts, &rep);
  EXPECT_EQ(on.regions, 1);
  EXPECT_EQ(rep["enclosed_groups"], 1);
  EXPECT_EQ(rep["enclosed_faces_moved"], 20);
}

TEST(DetectorsRegionGrowing, DeclaresOptionsAndRejectsOutOfRange) {
  Registry::instance().load_plugins();
  const StageInfo* info = Registry::instance().find(kRG);
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->doc, "docs/detectors.md");
  const Options o = default_options(*info);
  EXPECT_EQ(o.get_double("angle_threshold_deg"), 25);
  EXPECT_EQ(o.get_double("w_flatness"), 0.4);
  EXPECT_EQ(o.get_double("w_compactness"), 0.3);
  EXPECT_EQ(o.get_double("w_normal"), 0.3);
  EXPECT_EQ(o.get_string("write_labels"), "");
  EXPECT_TRUE(o.get_bool("absorb_enclosed"));
  EXPECT_EQ(o.get_double("enclosed_max_fraction"), 0.1);
  EXPECT_EQ(o.get_double("enclosed_border_fraction"), 0.75);
  EXPECT_THROW(default_options(*info, {{"enclosed_border_fraction", 0.4}}), std::invalid_argument);
  EXPECT_TRUE(o.get_bool("coplanar_grouping"));
  EXPECT_TRUE(o.get_bool("curved_surfaces"));
  EXPECT_EQ(o.get_double("coplanar_max_offset"), 0.25);
  EXPECT_THROW(default_options(*info, {{"coplanar_angle_deg", 91}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"speckle_max_fraction", 1.5}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"angle_threshold_deg", 95}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"angle_treshold_deg", 20}}), std::invalid_argument);
}

TEST(DetectorsRegionGrowing, FragmentedPlaneIsOneRegionAndUntexturedFacesStayOutside) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(6, 5, 256, "page.png");
  m.faces[7].page = kNoPage;  // one untextured face
  m.faces[7].vt = {kNoIndex, kNoIndex, kNoIndex};
  const tmesh::Detection d = tmesh::run_detector(kRG, m);
  expect_valid(m, d.regions);
  EXPECT_EQ(d.regions.num_regions, 1);
  EXPECT_EQ(d.regions.face_region[7], -1);
  EXPECT_EQ(d.regions.num_regions, 1);
  EXPECT_EQ(d.report["textured_faces"], 59);
}

TEST(DetectorsRegionGrowing, JaggedBordersCaseBeatsAngleGrowing) {
  const tmesh::Case c = tmesh::jagged_case();
  const auto rg = score(c, kRG);
  const auto ag = score(c, kAG);
  score(c, kRG, {{"jagged_borders", false}});
  EXPECT_GE(rg.accuracy, 0.97);
  EXPECT_EQ(rg.regions, 2);
  // Angle growing fragments the noisy planes into many small regions with jagged borders.
  EXPECT_GT(rg.accuracy, ag.accuracy + 0.03);
  EXPECT_GE(ag.regions, 5 * rg.regions);
}

TEST(DetectorsRegionGrowing, StripCaseDissolvesTheLedgeIntoTheFacade) {
  const tmesh::Case c = tmesh::strip_case();
  json rep;
  const auto rg = score(c, kRG, json::object(), &rep);
  const auto off = score(c, kRG, {{"elongated_strips", false}});
  const auto ag = score(c, kAG);
  EXPECT_GE(rg.accuracy, 0.99);
  EXPECT_EQ(rg.regions, 1);
  EXPECT_GE(rep["strip_regions"].get<int>(), 2);
  EXPECT_GT(rg.accuracy, off.accuracy + 0.05);
  EXPECT_GT(rg.accuracy, ag.accuracy + 0.05);
}

TEST(DetectorsRegionGrowing, CurvedCornerDoesNotJoinTheTwoFacadesAndTheColumnStaysWhole) {
  const tmesh::Case c = tmesh::curved_case();
  json rep;
  const auto rg = score(c, kRG, json::object(), &rep);
  // note: curved_surfaces (large cylinders) would also make the column whole: both are off here.
  const json no_curved = {{"curved_components", false}, {"curved_surfaces", false}};
  const auto off = score(c, kRG, no_curved);
  const auto ag = score(c, kAG);
  const tmesh::Detection d = tmesh::run_detector(kRG, c.mesh);
  const tmesh::Detection d_off = tmesh::run_detector(kRG, c.mesh, no_curved);
  std::set<int> column, column_off;
  int a = -1, b = -1;
  for (size_t f = 0; f < c.truth.size(); ++f) {
    if (c.truth[f] == 4) column.insert(d.regions.face_region[f]), column_off.insert(d_off.regions.face_region[f]);
    if (c.truth[f] == 0) a = d.regions.face_region[f];
    if (c.truth[f] == 1) b = d.regions.face_region[f];
  }
  EXPECT_NE(a, b);                     // the rounded corner does not join facades A and B
  EXPECT_EQ(column.size(), 1u);        // the column is one component...
  EXPECT_GE(column_off.size(), 3u);    // ...which plain growing cuts into pieces
  EXPECT_GE(rep["curved_components"].get<int>(), 1);
  EXPECT_GT(rg.accuracy, off.accuracy);
  EXPECT_GT(rg.accuracy, ag.accuracy + 0.1);
}

TEST(DetectorsRegionGrowing, ChartWrappingACornerIsSplit) {
  const tmesh::Case c = tmesh::corner_chart_case();
  json rep;
  const auto on = score(c, kRG, json::object(), &rep);
  const auto off = score(c, kRG, {{"split_nonplanar_patches", false}});
  EXPECT_EQ(rep["patches_split"], 4);
  EXPECT_GE(on.accuracy, 0.99);
  EXPECT_EQ(on.regions, 2);
  EXPECT_GT(on.accuracy, off.accuracy);
}

TEST(DetectorsRegionGrowing, WritesLabelsThatDetectorsLabelsReadsBackAndAColoredModel) {
  const tmesh::Case c = tmesh::jagged_case();
  const std::string dir = texdefrag::testing::temp_dir();
  for (const std::string ext : {".txt", ".json"}) {
    // Side outputs are names in the output folder, written through the run's write service.
    OutputSet outputs(dir, {});
    const tmesh::Detection d = tmesh::run_detector(
        kRG, c.mesh, {{"write_labels", "regions" + ext}, {"write_colored", "colored" + ext + ".obj"}}, {}, &outputs);
    const std::string labels = dir + "/regions" + ext;
    const std::string colored = dir + "/colored" + ext + ".obj";
    EXPECT_FALSE(std::filesystem::exists(labels)) << "visible before the set is committed";
    outputs.commit();
    const tmesh::Detection back = tmesh::run_detector("detectors.labels", c.mesh, {{"path", labels}});
    EXPECT_EQ(back.regions.face_region, d.regions.face_region);
    EXPECT_EQ(back.regions.num_regions, d.regions.num_regions);
    ASSERT_TRUE(std::filesystem::exists(colored));
    const TexturedMesh cm = read_obj(colored);
    ASSERT_EQ(cm.faces.size(), c.mesh.faces.size());
    ASSERT_EQ(cm.pages.size(), 1u);
    // Faces of one region share one palette texcoord, different regions different ones.
    for (size_t f = 1; f < cm.faces.size(); ++f)
      EXPECT_EQ(cm.faces[f].vt[0] == cm.faces[0].vt[0], d.regions.face_region[f] == d.regions.face_region[0]);
  }
}

TEST(DetectorsRegionGrowing, ProgressCanCancel) {
  const tmesh::Case c = tmesh::jagged_case();
  EXPECT_THROW(tmesh::run_detector(kRG, c.mesh, json::object(), [](const std::string&, double f) { return f < 0.5; }),
               Cancelled);
}

TEST(DetectorsRegionGrowing, CoplanarPiecesSeparatedByARidgeJoin) {
  // Two wall pieces of 80 faces each, in one plane, touching only a ridge whose panels stand 60
  // degrees out of the wall (depth 0.87 m over 0.5 m): growth cannot cross it, the ridge panels are
  // strips that fit no plane within 40 degrees and are not enclosed (their ends are open), so
  // without coplanar grouping the wall stays in two regions.
  const tmesh::Case c = ridge_wall(0.866);
  ASSERT_EQ(c.mesh.faces.size(), 176u);
  const tmesh::Detection off = tmesh::run_detector(kRG, c.mesh, {{"coplanar_grouping", false}});
  expect_valid(c.mesh, off.regions);
  EXPECT_NE(region_of_truth(c, off.regions, 0), region_of_truth(c, off.regions, 1));
  EXPECT_EQ(off.regions.num_regions, 4);
  const tmesh::Detection on = tmesh::run_detector(kRG, c.mesh);
  expect_valid(c.mesh, on.regions);
  EXPECT_EQ(region_of_truth(c, on.regions, 0), region_of_truth(c, on.regions, 1));
  EXPECT_EQ(on.report["coplanar_joins"], 1);
  EXPECT_EQ(on.report["coplanar_joins_across_speckle"], 1);
  // The ridge panels stand 60 degrees out of the wall: not speckle on its plane (45 degrees).
  EXPECT_NE(region_of_truth(c, on.regions, 2), region_of_truth(c, on.regions, 0));
  EXPECT_EQ(on.regions.num_regions, 3);
  // With a zero angle tolerance no pair passes.
  EXPECT_EQ(tmesh::run_detector(kRG, c.mesh, {{"coplanar_angle_deg", 0.0}}).regions.num_regions, 4);
}

TEST(DetectorsRegionGrowing, CoplanarGroupingNeverJoinsAWallAndARoof) {
  // The noisy wall + roof of Figure 3a and the chart wrapping the crease, with every distance
  // tolerance of the refinement opened up: the angle tests alone keep the 90-degree planes apart.
  const json loose = {{"coplanar_max_rms", 1000.0}, {"coplanar_max_offset", 1000.0},
                      {"speckle_max_distance", 1000.0}, {"speckle_max_fraction", 1.0}, {"coplanar_min_faces", 1}};
  for (const tmesh::Case& c : {tmesh::jagged_case(), tmesh::corner_chart_case()}) {
    json rep;
    const auto s = score(c, kRG, loose, &rep);
    EXPECT_EQ(s.regions, 2) << c.name;
    EXPECT_EQ(s.under_segmented, 0) << c.name;
    EXPECT_DOUBLE_EQ(s.accuracy, 1.0) << c.name;
    EXPECT_GT(rep["coplanar_rejections"]["angle"].get<int>(), 0) << c.name;  // the pair was considered
  }
}

TEST(DetectorsRegionGrowing, RecessedWindowJoinsOnlyWhenTheStepIsBelowTheOffsetTolerance) {
  // Our decision: a window plane parallel to its facade joins it when the step is under
  // coplanar_max_offset (0.25) mean edge lengths, which photogrammetry at this resolution cannot
  // resolve; a deeper recess is a plane of its own. Mean edge here ~0.55 m: tolerance ~0.14 m.
  // Enclosed rule off: it would take the window and reveals into the wall whatever the depth (they
  // are a small cluster enclosed by the wall).
  const json iso = {{"absorb_enclosed", false}};
  for (const double depth : {0.05, 0.2, 0.5}) {
    const tmesh::Case c = recessed_window(depth);
    const tmesh::Detection d = tmesh::run_detector(kRG, c.mesh, iso);
    const tmesh::Detection d_off = tmesh::run_detector(kRG, c.mesh, {{"absorb_enclosed", false}, {"coplanar_grouping", false}});
    expect_valid(c.mesh, d.regions);
    std::printf("recess %.2f m: mean edge %.3f, wall and window %s, %d regions (%d without grouping)\n", depth,
                d.report["mean_edge_length"].get<double>(),
                region_of_truth(c, d.regions, 0) == region_of_truth(c, d.regions, 1) ? "joined" : "apart",
                d.regions.num_regions, d_off.regions.num_regions);
    EXPECT_NE(region_of_truth(c, d_off.regions, 0), region_of_truth(c, d_off.regions, 1)) << depth;
    if (depth < 0.1)
      EXPECT_EQ(region_of_truth(c, d.regions, 0), region_of_truth(c, d.regions, 1)) << depth;
    else
      EXPECT_NE(region_of_truth(c, d.regions, 0), region_of_truth(c, d.regions, 1)) << depth;
  }
  // A 20 cm recess joins when the tolerance is a mean edge.
  const tmesh::Case c = recessed_window(0.2);
  const tmesh::Detection wide = tmesh::run_detector(kRG, c.mesh, {{"absorb_enclosed", false}, {"coplanar_max_offset", 1.0}});
  EXPECT_EQ(region_of_truth(c, wide.regions, 0), region_of_truth(c, wide.regions, 1));
}

TEST(DetectorsRegionGrowing, SiloCutIntoPlanarPiecesBecomesOneRegion) {
  // Growth with a 25-degree threshold cuts the silo into pieces of about 50 degrees; their borders
  // are smooth (7.5 degrees between facets) and the union is a cylinder, so curved_surfaces joins
  // them. The small-curved-component rule cannot: each piece is over 2% of the area.
  for (const double noise : {0.0, 0.05}) {
    const tmesh::Case c = silo(noise);
    ASSERT_EQ(c.mesh.faces.size(), 2u * 48 * 8 + 160);
    json rep;
    const auto on = score(c, kRG, json::object(), &rep);
    const auto off = score(c, kRG, {{"curved_surfaces", false}});
    EXPECT_GE(off.over_segmented, 1) << noise;   // the silo is split without the refinement
    EXPECT_EQ(on.regions, 2) << noise;           // silo and wall
    EXPECT_DOUBLE_EQ(on.accuracy, 1.0) << noise;
    EXPECT_GE(rep["cylinder_joins"].get<int>(), 2) << noise;
  }
}

TEST(DetectorsRegionGrowing, CurvedSurfacesLeaveABoxBuildingsCreasesAlone) {
  // Four walls around a vertical axis have normals perpendicular to it, as a cylinder's do; their
  // borders are creases (the whole 90-degree turn happens there), so none joins.
  const tmesh::Case c = tmesh::building_case(4000);
  json rep;
  const auto s = score(c, kRG, {{"cylinder_max_rms", 1000.0}}, &rep);
  EXPECT_EQ(rep["cylinder_joins"], 0);
  EXPECT_EQ(s.under_segmented, 0);
  EXPECT_GE(s.accuracy, 0.99);
}
