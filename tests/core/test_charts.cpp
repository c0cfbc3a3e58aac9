// Topology and charts on meshes small enough to check by hand, and invariants on real tiles.
#include "texdefrag/core/chart_mesh.h"
#include "texdefrag/core/charts.h"
#include "texdefrag/core/distortion.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace texdefrag;

namespace {

/// Unit square in z=0 split along (0,0)-(1,1); one 10x10 page.
/// p0=(0,0) p1=(1,0) p2=(0,1) p3=(1,1); faces (0,1,3) and (0,3,2).
TexturedMesh square(bool split_uv, bool duplicate_positions) {
  TexturedMesh m;
  m.pages.push_back({"m", "none.png", 10, 10});
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.texcoords = {{0, 0}, {0.5, 0}, {0, 0.5}, {0.5, 0.5}};
  Face a, b;
  a.v = {0, 1, 3};
  a.vt = {0, 1, 3};
  b.v = {0, 3, 2};
  b.vt = {0, 3, 2};
  a.page = b.page = 0;
  if (duplicate_positions) {
    // Second face gets its own copies of positions and texcoords, same values.
    m.positions.push_back({0, 0, 0});
    m.positions.push_back({1, 1, 0});
    m.positions.push_back({0, 1, 0});
    b.v = {4, 5, 6};
    m.texcoords.push_back({0, 0});
    m.texcoords.push_back({0.5, 0.5});
    m.texcoords.push_back({0, 0.5});
    b.vt = {4, 5, 6};
  }
  if (split_uv) {
    // Second face moved by +0.5 in u: (5,0) (10,5) (5,5) in texels.
    m.texcoords.push_back({0.5, 0});
    m.texcoords.push_back({1.0, 0.5});
    m.texcoords.push_back({0.5, 0.5});
    const int n = static_cast<int>(m.texcoords.size());
    b.vt = {n - 3, n - 2, n - 1};
  }
  m.faces = {a, b};
  return m;
}

}  // namespace

TEST(Topology, WeldsDuplicatedPositionsAndCountsEdges) {
  const TexturedMesh m = square(false, true);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.report.welded_vertices, 4u);
  EXPECT_EQ(t.report.edges, 5u);
  EXPECT_EQ(t.report.boundary_edges, 4u);
  EXPECT_EQ(t.report.non_manifold_edges, 0u);
  EXPECT_EQ(t.report.degenerate_faces, 0u);
  EXPECT_EQ(t.opposite_face(0, 2), 1);   // local edge 2 of face 0 joins p3 and p0: the diagonal
  EXPECT_EQ(t.opposite_face(0, 0), -1);  // p0-p1: boundary
}

TEST(Topology, ReportsNonManifoldDegenerateAndDuplicateFaces) {
  TexturedMesh m = square(false, false);
  m.positions.push_back({0.5, 0.5, 1});  // p4 above the diagonal
  Face c;
  c.v = {0, 3, 4};  // third face on edge (0,3)
  c.vt = {0, 3, 3};
  c.page = 0;
  Face d;  // degenerate: two corners on p1
  d.v = {1, 1, 3};
  d.vt = {1, 1, 3};
  d.page = 0;
  Face e = m.faces[0];  // duplicate of face 0, other orientation
  e.v = {3, 1, 0};
  e.vt = {3, 1, 0};
  m.faces.push_back(c);
  m.faces.push_back(d);
  m.faces.push_back(e);
  const Topology t = build_topology(m);
  EXPECT_EQ(t.report.degenerate_faces, 1u);
  EXPECT_EQ(t.report.duplicate_faces, 1u);
  EXPECT_GE(t.report.non_manifold_edges, 1u);
  EXPECT_GE(t.report.non_manifold_vertices, 1u);
  EXPECT_EQ(t.face_vertex.size(), 5u);  // nothing dropped
}

TEST(Charts, SharedUvIsOneChart) {
  for (bool dup : {false, true}) {
    const TexturedMesh m = square(false, dup);
    const Topology t = build_topology(m);
    const ChartSet cs = build_charts(m, t);
    EXPECT_EQ(cs.atlas.num_charts, 1) << dup;
    EXPECT_EQ(cs.seam_edges, 0u);
    EXPECT_EQ(cs.atlas.wedge_uv.size(), 4u);
    ASSERT_EQ(cs.stats.size(), 1u);
    EXPECT_DOUBLE_EQ(cs.stats[0].uv_area, 25.0);
    EXPECT_DOUBLE_EQ(cs.stats[0].area_3d, 1.0);
    EXPECT_DOUBLE_EQ(cs.stats[0].uv_border, 20.0);
    EXPECT_NEAR(std::abs(cs.stats[0].normal.z()), 1.0, 1e-12);
    EXPECT_NEAR(cs.stats[0].eigenvalues.x(), 0.0, 1e-12);
  }
}

TEST(Charts, SplitUvIsTwoChartsWithOneSeam) {
  const TexturedMesh m = square(true, false);
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  EXPECT_EQ(cs.atlas.num_charts, 2);
  EXPECT_EQ(cs.seam_edges, 1u);
  ASSERT_EQ(cs.chains.size(), 1u);
  EXPECT_EQ(cs.chains[0].chart_a, 0);
  EXPECT_EQ(cs.chains[0].chart_b, 1);
  EXPECT_NEAR(cs.seam_length_3d, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(cs.uv_border_length, 20 + 10 * std::sqrt(2.0), 1e-9);
  EXPECT_EQ(cs.atlas.wedge_uv.size(), 6u);
  EXPECT_EQ(cs.chart_chains[0].size(), 1u);
  EXPECT_EQ(cs.chart_chains[1].size(), 1u);
}

TEST(Charts, HalfSplitEdgeIsASeam) {
  // Only one endpoint differs: the edge is still a seam (both endpoints must match).
  TexturedMesh m = square(false, false);
  m.texcoords.push_back({0.5, 0.6});  // moves p3's UV for face 1 only
  m.faces[1].vt = {0, 4, 2};
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  EXPECT_EQ(cs.atlas.num_charts, 2);
  EXPECT_EQ(cs.seam_edges, 1u);
}

TEST(Charts, DifferentPagesAreDifferentCharts) {
  TexturedMesh m = square(false, false);
  m.pages.push_back({"m2", "none2.png", 10, 10});
  m.faces[1].page = 1;
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  EXPECT_EQ(cs.atlas.num_charts, 2);
  EXPECT_EQ(cs.atlas.chart_page[0], 0);
  EXPECT_EQ(cs.atlas.chart_page[1], 1);
}

TEST(Charts, UntexturedFacesHaveNoChart) {
  TexturedMesh m = square(false, false);
  m.faces[1].page = kNoPage;
  m.faces[1].vt = {kNoIndex, kNoIndex, kNoIndex};
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  EXPECT_EQ(cs.atlas.num_charts, 1);
  EXPECT_EQ(cs.atlas.face_chart[1], -1);
  EXPECT_EQ(cs.seam_edges, 0u);
}

TEST(Charts, FragmentedGridHasOneChartPerTriangle) {
  const TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(3, 2, 64, "x.png");
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  EXPECT_EQ(cs.atlas.num_charts, 12);
  EXPECT_EQ(t.report.welded_vertices, 12u);  // 4x3 grid points
  // Interior edges of a 3x2 quad grid with diagonals: 3*2 diagonals + 2*2 vertical + 3*1 horizontal.
  EXPECT_EQ(cs.seam_edges, 13u);
}

TEST(Charts, CompactRenumbersCharts) {
  const TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(2, 1, 64, "x.png");
  const Topology t = build_topology(m);
  ChartSet cs = build_charts(m, t);
  Atlas a = cs.atlas;
  for (int& c : a.face_chart)
    if (c == 2) c = 0;
  EXPECT_EQ(a.compact(), 3);
  EXPECT_EQ(a.face_chart, (std::vector<int>{0, 1, 0, 2}));
}

TEST(Distortion, ScaleAndFlip) {
  const Vec2 o[3] = {{0, 0}, {1, 0}, {0, 1}};
  const Vec2 s2[3] = {{0, 0}, {2, 0}, {0, 2}};
  const Vec2 fl[3] = {{0, 0}, {0, 1}, {1, 0}};
  Eigen::Matrix2d J;
  ASSERT_TRUE(uv_jacobian(o, s2, J));
  EXPECT_NEAR(arap_error(J), 2.0, 1e-12);
  EXPECT_NEAR(symmetric_dirichlet(J), 4 + 4 + 0.25 + 0.25, 1e-12);
  ASSERT_TRUE(uv_jacobian(o, fl, J));
  EXPECT_NEAR(arap_error(J), 4.0, 1e-12);  // s = (1, -1)
  EXPECT_TRUE(std::isinf(symmetric_dirichlet(J)));
  const Vec2 zero[3] = {{0, 0}, {1, 0}, {2, 0}};
  EXPECT_FALSE(uv_jacobian(zero, s2, J));
}

TEST(Distortion, MirrorGroupsReadAReflectedPieceThroughTheMirrorAndAFoldedOneAsFlipped) {
  // Output chart 0: input chart 1 laid out as is (two faces, turn +), input chart 2 reflected
  // (det J < 0) but turning like chart 0 (turn +): a welded mirror image. Output chart 5: input
  // chart 3 reflected and turning against the rest of chart 5 (area 4 against 1): a folded piece.
  const Vec2 ccw[3] = {{0, 0}, {1, 0}, {0, 1}};
  const Eigen::Matrix2d identity = Eigen::Matrix2d::Identity(), mirror = Eigen::Vector2d(1, -1).asDiagonal();
  const Vec2 cw[3] = {{0, 0}, {0, 1}, {1, 0}};
  MirrorGroups g;
  g.add(0, 1, 2.0, identity, ccw);
  g.add(0, 1, 2.0, identity, ccw);
  g.add(0, 2, 1.0, mirror, ccw);
  g.add(5, 4, 4.0, identity, ccw);
  g.add(5, 3, 1.0, mirror, cw);
  EXPECT_FALSE(g.mirrored(0, 1));
  EXPECT_TRUE(g.mirrored(0, 2));
  EXPECT_FALSE(g.mirrored(5, 3));  // turns against its chart: its faces count as flipped
  EXPECT_FALSE(g.mirrored(5, 4));
  EXPECT_FALSE(g.mirrored(7, 1));  // never added
  // The sums: a flipped face counts in the ARAP mean, not in the symmetric Dirichlet one.
  DistortionSums sums;
  sums.add(2.0, identity);
  sums.add(1.0, mirror);
  EXPECT_EQ(sums.flipped, 1u);
  EXPECT_DOUBLE_EQ(sums.weight, 3.0);
  EXPECT_DOUBLE_EQ(sums.mean_arap(), (2.0 * 0 + 1.0 * 4) / 3.0);  // mirror: s = (1, -1), (1-1)^2 + (-1-1)^2 = 4
  EXPECT_DOUBLE_EQ(sums.mean_symmetric_dirichlet(), 4.0);          // identity alone: 1 + 1 + 1 + 1
}

TEST(ChartsReal, InvariantsOnRealTiles) {
  const auto models = texdefrag::testing::real_models(25000);
  if (models.empty()) GTEST_SKIP() << "shared data absent: ../shared/data";
  for (const std::string& path : models) {
    const TexturedMesh m = read_obj(path);
    const Topology t = build_topology(m);
    const ChartSet cs = build_charts(m, t);
    size_t faces_in_charts = 0;
    for (const auto& s : cs.stats) faces_in_charts += static_cast<size_t>(s.faces);
    size_t textured = 0;
    for (const Face& f : m.faces) textured += f.page != kNoPage;
    EXPECT_EQ(faces_in_charts, textured) << path;
    EXPECT_GT(cs.atlas.num_charts, 0) << path;
    if (path.find("contextcapture") != std::string::npos) {
      EXPECT_LT(t.report.welded_vertices, m.positions.size()) << path;  // seams duplicate positions
    }
    // Input UVs against themselves: no distortion.
    const DistortionSummary d = atlas_distortion(m, cs.atlas);
    EXPECT_LT(d.arap, 1e-20) << path;  // zero up to the SVD's rounding
    EXPECT_EQ(d.flipped, 0u) << path;
    // Every seam edge joins two different charts or a chart to itself across a cut.
    for (const SeamChain& ch : cs.chains) EXPECT_LE(ch.chart_a, ch.chart_b);
    std::printf("%s: %zu faces, V3 %zu, %d charts (%zu zero-area), %zu seam edges, %zu non-manifold edges\n",
                path.c_str(), m.faces.size(), t.report.welded_vertices, cs.atlas.num_charts, cs.zero_area_charts,
                cs.seam_edges, t.report.non_manifold_edges);
  }
}

TEST(ChartMesh, GridChartIsADiskWithUvPositions) {
  const TexturedMesh m = texdefrag::testing::grid_mesh(3, 2, 100, "x.png");
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  ASSERT_EQ(cs.atlas.num_charts, 1);
  const ChartMesh cm = chart_mesh(cs.atlas, 0);
  EXPECT_EQ(cm.mesh.n_faces(), 12u);
  EXPECT_EQ(cm.mesh.n_vertices(), 12u);  // 4 x 3 grid points
  EXPECT_TRUE(cm.refused.empty());
  EXPECT_EQ(boundary_loops(cm.mesh), 1);
  // Vertex positions are the wedge UVs in texels.
  for (auto v : cm.mesh.vertices()) {
    const Vec2& uv = cs.atlas.wedge_uv[static_cast<size_t>(cm.wedge_of[static_cast<size_t>(v.idx())])];
    EXPECT_EQ(cm.mesh.point(v)[0], uv.x());
    EXPECT_EQ(cm.mesh.point(v)[1], uv.y());
  }
}

TEST(ChartMesh, NonManifoldFacesAreListedNotDropped) {
  // Three triangles on one UV edge: OpenMesh refuses the third, which is reported.
  TexturedMesh m = square(false, false);
  m.positions.push_back({0.5, 0.5, 1});
  m.texcoords.push_back({0.8, 0.1});
  Face c;
  c.v = {0, 3, 4};
  c.vt = {0, 3, 4};
  c.page = 0;
  m.faces.push_back(c);
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  ASSERT_EQ(cs.atlas.num_charts, 1);
  const ChartMesh cm = chart_mesh(cs.atlas, 0);
  EXPECT_EQ(cm.mesh.n_faces() + cm.refused.size(), 3u);
  EXPECT_EQ(cm.refused.size(), 1u);
}
