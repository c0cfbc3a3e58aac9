// Unit tests of the merge engine's pieces: rigid fit, segment crossings, planarity terms, the shared
// per-triangle algebra, the ARAP solver, and the engine itself on hand-built meshes.
#include "arap_solver.h"
#include "engine_internal.h"
#include "geometry2d.h"
#include "local_problem.h"
#include "merge_engine.h"
#include "test_support.h"
#include "test_engine_run.h"

#include "texdefrag/core/distortion.h"
#include "texdefrag/util/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <functional>
#include <map>

#include <cmath>
#include <random>

namespace texdefrag::merge {
namespace {

TEST(MergeEngine, RigidFitRecoversRotationAndTranslation) {
  const double th = 0.7;
  Rigid2 truth;
  truth.R << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
  truth.t = Vec2(3, -2);
  std::vector<Vec2> p = {{0, 0}, {1, 0}, {1, 2}, {-1, 3}}, q;
  for (const Vec2& x : p) q.push_back(truth(x));
  const Rigid2 m = fit_rigid(p, q);
  EXPECT_NEAR((m.R - truth.R).norm(), 0, 1e-12);
  EXPECT_NEAR((m.t - truth.t).norm(), 0, 1e-12);
}

TEST(MergeEngine, RigidFitNeverReflects) {
  // Mirrored target: the best rotation is not a reflection, det stays +1.
  std::vector<Vec2> p = {{0, 0}, {2, 0}, {0, 1}}, q = {{0, 0}, {-2, 0}, {0, 1}};
  const Rigid2 m = fit_rigid(p, q);
  EXPECT_NEAR(m.R.determinant(), 1.0, 1e-12);
}

TEST(MergeEngine, ImproperFitRecoversAReflection) {
  // q = mirror of p across the line at 30 degrees, then shifted: det R = -1, exact recovery.
  const double th = M_PI / 3;  // reflection across angle th/2 = [[cos th, sin th], [sin th, -cos th]]
  Rigid2 truth;
  truth.R << std::cos(th), std::sin(th), std::sin(th), -std::cos(th);
  truth.t = Vec2(-1, 5);
  std::vector<Vec2> p = {{0, 0}, {2, 0}, {0, 1}, {3, 4}}, q;
  for (const Vec2& x : p) q.push_back(truth(x));
  const Rigid2 m = fit_improper(p, q);
  EXPECT_NEAR(m.R.determinant(), -1.0, 1e-12);
  EXPECT_NEAR((m.R - truth.R).norm(), 0, 1e-12);
  EXPECT_NEAR((m.t - truth.t).norm(), 0, 1e-12);
}

TEST(MergeEngine, RigidFitSinglePointIsTranslation) {
  const Rigid2 m = fit_rigid({{1, 1}}, {{4, 5}});
  EXPECT_NEAR((m.R - Eigen::Matrix2d::Identity()).norm(), 0, 1e-15);
  EXPECT_NEAR((m(Vec2(1, 1)) - Vec2(4, 5)).norm(), 0, 1e-15);
}

TEST(MergeEngine, SegmentsCross) {
  EXPECT_TRUE(segments_cross({0, 0}, {2, 2}, {0, 2}, {2, 0}));
  EXPECT_FALSE(segments_cross({0, 0}, {1, 1}, {0, 2}, {2, 2}));
  EXPECT_FALSE(segments_cross({0, 0}, {1, 0}, {1, 0}, {2, 1}));  // touching endpoint
  EXPECT_FALSE(segments_cross({0, 0}, {2, 0}, {1, 0}, {3, 0}));  // collinear overlap is not proper
}

TEST(MergeEngine, AnyCrossingSkipsAdjacentAndFindsCrossing) {
  std::vector<Segment> all = {{0, 1, {0, 0}, {1, 0}}, {1, 2, {1, 0}, {1, 1}}};
  std::vector<Segment> moved = {{2, 3, {1, 1}, {0.5, -1}}};
  EXPECT_TRUE(any_crossing(moved, all));  // crosses segment 0-1
  moved = {{2, 3, {1, 1}, {0.5, 2}}};
  EXPECT_FALSE(any_crossing(moved, all));
  // Shares wedge 1 with the second segment only; touches nothing else.
  moved = {{1, 4, {1, 0}, {2, -1}}};
  EXPECT_FALSE(any_crossing(moved, all));
}

TEST(MergeEngine, AnyCrossingManySegments) {
  // A long zigzag of moved segments crossing one far segment at the end.
  std::vector<Segment> moved, all;
  for (int i = 0; i < 500; ++i) moved.push_back({i, i + 1, {double(i), 0}, {double(i + 1), 0.5}});
  all.push_back({1000, 1001, {499.5, -1}, {499.6, 1}});
  EXPECT_TRUE(any_crossing(moved, all));
  all[0] = {1000, 1001, {499.5, 1}, {499.6, 2}};
  EXPECT_FALSE(any_crossing(moved, all));
}

TEST(MergeEngine, TrianglesOverlapByHand) {
  using V = Eigen::Vector2d;
  auto T = [](std::array<int, 3> w, V a, V b, V c) {
    Tri2 t;
    t.w = w;
    t.p = {a, b, c};
    return t;
  };
  const Tri2 a = T({0, 1, 2}, V(0, 0), V(2, 0), V(0, 2));
  // Sharing an edge, on the other side: no overlap; on the same side (a fold): overlap.
  EXPECT_FALSE(triangles_overlap(a, T({1, 2, 3}, V(2, 0), V(0, 2), V(2, 2))));
  EXPECT_TRUE(triangles_overlap(a, T({1, 2, 3}, V(2, 0), V(0, 2), V(0.5, 0.5))));
  // Sharing a vertex: a fan that wraps over the first triangle overlaps; beside it does not.
  EXPECT_TRUE(triangles_overlap(a, T({0, 4, 5}, V(0, 0), V(1.5, 0.2), V(0.2, 1.5))));
  EXPECT_FALSE(triangles_overlap(a, T({0, 4, 5}, V(0, 0), V(-1, 0), V(0, -1))));
  // Disjoint ids: contained, crossing, apart, touching at a point.
  EXPECT_TRUE(triangles_overlap(a, T({6, 7, 8}, V(0.2, 0.2), V(0.6, 0.2), V(0.2, 0.6))));
  EXPECT_TRUE(triangles_overlap(a, T({6, 7, 8}, V(1, -1), V(1, 1), V(3, 0))));
  EXPECT_FALSE(triangles_overlap(a, T({6, 7, 8}, V(3, 3), V(4, 3), V(3, 4))));
  EXPECT_FALSE(triangles_overlap(a, T({6, 7, 8}, V(2, 0), V(3, 0), V(3, 1))));
  // any_triangle_overlap: moved against the rest and against each other.
  std::vector<Tri2> rest = {a};
  EXPECT_TRUE(any_triangle_overlap({T({6, 7, 8}, V(0.2, 0.2), V(0.6, 0.2), V(0.2, 0.6))}, rest));
  EXPECT_FALSE(any_triangle_overlap({T({6, 7, 8}, V(3, 3), V(4, 3), V(3, 4))}, rest));
  EXPECT_TRUE(any_triangle_overlap({T({6, 7, 8}, V(3, 3), V(4, 3), V(3, 4)), T({9, 10, 11}, V(3.2, 3.2), V(3.5, 3.2), V(3.2, 3.5))}, {}));
}

TEST(MergeEngine, PlanarityIsTheDetectorsModuleWithOrientedNormals) {
  // The engine scores charts with detectors/common/planarity.h (one module, one orientation rule):
  // normals oriented by the 3D winding, theta in [0, pi], the normal term 0 past 90 degrees.
  detectors::PlaneMoments m;
  m.add_triangle({0, 0, 0}, {1, 0, 0}, {1, 1, 0});
  m.add_triangle({0, 0, 0}, {1, 1, 0}, {0, 1, 0});
  const detectors::PlaneFit fit = detectors::fit_plane(m);
  EXPECT_NEAR(m.area, 1.0, 1e-15);
  EXPECT_NEAR(fit.eigenvalues[0], 0.0, 1e-15);
  // Variance of a uniform [0,1] coordinate; fit_plane's closed-form eigensolver is accurate to
  // ~1e-9 relative on this doubled eigenvalue.
  EXPECT_NEAR(fit.eigenvalues[1], 1.0 / 12, 1e-9);
  EXPECT_NEAR(fit.eigenvalues[2], 1.0 / 12, 1e-9);
  EXPECT_NEAR(fit.normal.z(), 1.0, 1e-12);  // counter-clockwise seen from +z: +z, not -z
  const detectors::CpiWeights w;
  EXPECT_NEAR(detectors::planarity_index(fit, detectors::normal_angle(fit.normal, Vec3(0, 0, 2)), w),
              0.4 * 1 + 0.3 * 1 + 0.3 * 1, 1e-8);
  // A region facing the other way: theta = pi, the normal term is 0 (it was 1 in the engine's
  // former orientation-free copy).
  EXPECT_NEAR(detectors::planarity_index(fit, detectors::normal_angle(fit.normal, Vec3(0, 0, -1)), w),
              0.4 * 1 + 0.3 * 1, 1e-8);
  EXPECT_NEAR(detectors::planarity_index(fit, detectors::normal_angle(fit.normal, Vec3::Zero()), w), 0.7, 1e-8);
}

TEST(MergeEngine, SignedSingularValuesMatchCore) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int i = 0; i < 200; ++i) {
    Mat2 F;
    F << u(rng), u(rng), u(rng), u(rng);
    const Eigen::Vector2d a = signed_singular_values_2x2(F), b = texdefrag::signed_singular_values(F);
    EXPECT_NEAR((a - b).norm(), 0, 1e-12);
    EXPECT_NEAR(arap_error_2x2(F), texdefrag::arap_error(F), 1e-12);
    const Mat2 R = closest_rotation(F);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    EXPECT_NEAR((R.transpose() * R - Mat2::Identity()).norm(), 0, 1e-12);
  }
}

TEST(MergeEngine, GradientOperatorGivesDeformationGradient) {
  LocalProblem p;
  p.x = {{1, 1}, {4, 2}, {2, 5}};
  p.num_free = 3;
  p.tri = {{0, 1, 2}};
  Mat2 Dm;
  Dm << 2, 0, 0, 3;
  p.rest_inv = {Dm.inverse()};
  p.weight = {3};
  const Mat2 F = deformation_gradient(p, 0);
  Eigen::Matrix<double, 6, 1> x;
  x << 1, 1, 4, 2, 2, 5;
  const Eigen::Vector4d v = gradient_operator(p.rest_inv[0]) * x;
  EXPECT_NEAR(v[0], F(0, 0), 1e-15);
  EXPECT_NEAR(v[1], F(0, 1), 1e-15);
  EXPECT_NEAR(v[2], F(1, 0), 1e-15);
  EXPECT_NEAR(v[3], F(1, 1), 1e-15);
  EXPECT_NEAR(F(0, 0), 1.5, 1e-15);  // (4-1)/2
  EXPECT_NEAR(F(1, 1), 4.0 / 3, 1e-15);
}

TEST(MergeEngine, MaxInjectiveStepStopsAtCollapse) {
  LocalProblem p;
  p.x = {{0, 0}, {1, 0}, {0, 1}};
  p.num_free = 1;  // only the first corner moves
  p.tri = {{0, 1, 2}};
  p.rest_inv = {Mat2::Identity()};
  p.weight = {0.5};
  Eigen::VectorXd d(2);
  d << 1, 1;  // corner 0 moves towards the hypotenuse x + y = 1, reached at t = 0.5
  EXPECT_NEAR(max_injective_step(p, d), 0.5, 1e-12);
  d << -1, -1;  // moving away never collapses
  EXPECT_TRUE(std::isinf(max_injective_step(p, d)));
}

/// A 3x3-vertex square patch, the centre free, the ring pinned; the centre starts displaced.
LocalProblem centre_patch(const Vec2& centre) {
  LocalProblem p;
  p.x.push_back(centre);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i)
      if (!(i == 1 && j == 1)) p.x.emplace_back(i, j);
  auto id = [](int i, int j) { return (i == 1 && j == 1) ? 0 : 1 + j * 3 + i - ((j * 3 + i) > 4 ? 1 : 0); };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      for (const auto& t : {std::array<int, 3>{id(i, j), id(i + 1, j), id(i + 1, j + 1)},
                            std::array<int, 3>{id(i, j), id(i + 1, j + 1), id(i, j + 1)}}) {
        p.tri.push_back(t);
        p.rest_inv.push_back(Mat2::Identity());  // rest edge matrices are set below
        p.weight.push_back(0.5);
      }
    }
  // Rest = the undisplaced grid.
  std::vector<Vec2> rest = p.x;
  rest[0] = Vec2(1, 1);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    Mat2 Dm;
    Dm.col(0) = rest[static_cast<size_t>(p.tri[t][1])] - rest[static_cast<size_t>(p.tri[t][0])];
    Dm.col(1) = rest[static_cast<size_t>(p.tri[t][2])] - rest[static_cast<size_t>(p.tri[t][0])];
    p.rest_inv[t] = Dm.inverse();
  }
  p.num_free = 1;
  return p;
}

TEST(MergeEngine, ArapRestoresTheRestShape) {
  LocalProblem p = centre_patch({1.3, 0.8});
  EXPECT_GT(arap_energy(p), 1e-3);
  ArapSettings s;
  s.iterations = 100;
  s.tolerance = 1e-14;
  const SolveResult r = ArapSolver(s).solve(p);
  EXPECT_TRUE(r.ok);
  EXPECT_NEAR((p.x[0] - Vec2(1, 1)).norm(), 0, 1e-6);
  EXPECT_LT(arap_energy(p), 1e-10);
}

/// vec(F) (row-major) of triangle t of p as a 4x6 matrix of its corners' (x, y), read off
/// deformation_gradient() at unit corner positions (F is linear in them): independent of gradient_rows.
Mat46 gradient_by_unit_positions(const LocalProblem& p, size_t t) {
  LocalProblem one;
  one.tri = {{0, 1, 2}};
  one.rest_inv = {p.rest_inv[t]};
  Mat46 D;
  for (int c = 0; c < 6; ++c) {
    one.x.assign(3, Vec2::Zero());
    one.x[static_cast<size_t>(c / 2)][c % 2] = 1;
    const Mat2 F = deformation_gradient(one, 0);
    D.col(c) << F(0, 0), F(0, 1), F(1, 0), F(1, 1);
  }
  return D;
}

/// A 4x4-vertex grid, the 4 inner vertices free (first), the ring pinned; rest shapes sheared and
/// scaled per triangle, weights unequal, positions jittered, so no x-y coupling cancels by symmetry.
LocalProblem sheared_grid() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  LocalProblem p;
  std::vector<int> id(16);
  int next_free = 0, next_pinned = 4;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) id[static_cast<size_t>(j * 4 + i)] = (i % 3 && j % 3) ? next_free++ : next_pinned++;
  p.x.resize(16);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) p.x[static_cast<size_t>(id[static_cast<size_t>(j * 4 + i)])] = Vec2(i + u(rng), j + u(rng));
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      const int a = id[static_cast<size_t>(j * 4 + i)], b = id[static_cast<size_t>(j * 4 + i + 1)];
      const int c = id[static_cast<size_t>(j * 4 + i + 5)], d = id[static_cast<size_t>(j * 4 + i + 4)];
      for (const auto& t : {std::array<int, 3>{a, b, c}, std::array<int, 3>{a, c, d}}) {
        Mat2 Dm;
        Dm << 1.5 + u(rng), 0.7 + u(rng), u(rng), 0.8 + u(rng);
        p.tri.push_back(t);
        p.rest_inv.push_back(Dm.inverse());
        p.weight.push_back(1 + 3 * std::abs(u(rng)));
      }
    }
  p.num_free = 4;
  return p;
}

TEST(MergeEngine, ArapStepMatchesTheCoupledSystem) {
  // One local/global step of the solver (its n x n system for x and y) against the dense 2n x 2n
  // minimiser of sum_t w_t |D_t x - vec(R_t)|^2 over the free coordinates, R_t fixed at the start.
  LocalProblem p = sheared_grid();
  const int n = p.num_free;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(2 * n);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat46 D = gradient_by_unit_positions(p, t);
    const Mat2 R = closest_rotation(deformation_gradient(p, t));
    Eigen::Vector4d r;
    r << R(0, 0), R(0, 1), R(1, 0), R(1, 1);
    Eigen::Matrix<double, 6, 1> pinned = Eigen::Matrix<double, 6, 1>::Zero();
    for (int a = 0; a < 6; ++a) {
      const int v = p.tri[t][static_cast<size_t>(a / 2)];
      if (v >= n) pinned[a] = p.x[static_cast<size_t>(v)][a % 2];
    }
    const Eigen::Matrix<double, 6, 6> Kt = p.weight[t] * D.transpose() * D;
    const Eigen::Matrix<double, 6, 1> bt = p.weight[t] * D.transpose() * (r - D * pinned);
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va >= n) continue;
      rhs[2 * va + a % 2] += bt[a];
      for (int b = 0; b < 6; ++b) {
        const int vb = p.tri[t][static_cast<size_t>(b / 2)];
        if (vb < n) K(2 * va + a % 2, 2 * vb + b % 2) += Kt(a, b);
      }
    }
  }
  const Eigen::VectorXd expected = K.ldlt().solve(rhs);
  ArapSettings s;
  s.iterations = 1;
  s.tolerance = 0;
  ArapSolver(s).solve(p);
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(p.x[static_cast<size_t>(i)].x(), expected[2 * i], 1e-12) << i;
    EXPECT_NEAR(p.x[static_cast<size_t>(i)].y(), expected[2 * i + 1], 1e-12) << i;
  }
}

TEST(MergeEngine, GradientRowsAreTheGradientOperatorsNonzeroBlocks) {
  const LocalProblem p = sheared_grid();
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat23 G = gradient_rows(p.rest_inv[t]);
    Mat46 expected = Mat46::Zero();
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
        for (int k = 0; k < 3; ++k) expected(2 * i + j, 2 * k + i) = G(j, k);
    EXPECT_NEAR((gradient_by_unit_positions(p, t) - expected).norm(), 0, 1e-12) << t;
    EXPECT_EQ(gradient_operator(p.rest_inv[t]), expected) << t;
  }
}

TEST(MergeEngine, ArapUntanglesAnInvertedStart) {
  LocalProblem p = centre_patch({2.5, 1.2});  // outside the ring: some triangles inverted
  EXPECT_GT(count_inverted(p), 0);
  const SolveResult r = ArapSolver().solve(p);
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(count_inverted(p), 0);
}

// ---- the engine on hand-built meshes (with the ARAP solver; stage tests live with the plugins)

TEST(MergeEngine, FragmentedGridBecomesOneChart) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(6, 5, 1024, "unused.png"));
  ASSERT_EQ(run.ctx.atlas.num_charts, 60);
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, MergeOptions{},
                                   solver, {});
  EXPECT_EQ(r.charts_in, 60u);
  EXPECT_EQ(r.charts_out, 1u);
  EXPECT_EQ(r.accepted, 59u);
  EXPECT_LT(r.distortion_out, 1e-12);
  test::expect_valid_atlas(run);
}

/// An 8 x 3 grid of unit quads (2 triangles each) in the plane z = 0; quad (i, j) belongs to chart
/// chart_of(i, j). Every chart has its own texture coordinates (the quad's position times 16 texels,
/// shifted by 40 texels per chart along u), so charts meet only at seams.
TexturedMesh chart_grid(const std::function<int(int, int)>& chart_of) {
  const int nx = 8, ny = 3, page = 1024;
  TexturedMesh m = test::one_page_mesh(page);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.positions.emplace_back(i, j, 0);
  auto vid = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int c = chart_of(i, j);
      const int corners[2][3][2] = {{{i, j}, {i + 1, j}, {i + 1, j + 1}}, {{i, j}, {i + 1, j + 1}, {i, j + 1}}};
      for (const auto& tri : corners) {
        Face f;
        f.page = 0;
        f.source_line = static_cast<int>(m.faces.size()) + 1;
        for (int k = 0; k < 3; ++k) {
          const int x = tri[k][0], y = tri[k][1];
          f.v[static_cast<size_t>(k)] = vid(x, y);
          f.vt[static_cast<size_t>(k)] = static_cast<int>(m.texcoords.size());
          m.texcoords.emplace_back((16.0 * x + 40.0 * c * 10) / page, (16.0 * y + 8) / page);
        }
        m.faces.push_back(f);
      }
    }
  return m;
}

TEST(MergeEngine, MMethodIslandLookaheadLiftsTheShortSeamRefusal) {
  // Strips A = quads 1..3 and B = quads 4..6 of the middle row share one edge: 1/8 of each one's
  // border, under the M-method's 0.2, so the seam is refused... unless merging them can close an
  // island (its IslandLookahead): A + B is an island inside chart C (everything else). A and B are
  // one region and C another, so A-B is the only candidate pair.
  auto strips = [](int i, int j) { return j == 1 && i >= 1 && i <= 3 ? 0 : j == 1 && i >= 4 && i <= 6 ? 1 : 2; };
  MergeOptions o;
  o.priority = Priority::MMethod;
  auto regions = [](const TexturedMesh& m) {
    std::vector<int> r(m.faces.size());
    for (size_t f = 0; f < m.faces.size(); ++f) {
      const Vec3 c = (m.corner_position(f, 0) + m.corner_position(f, 1) + m.corner_position(f, 2)) / 3;
      r[f] = c.y() > 1 && c.y() < 2 && c.x() > 1 && c.x() < 7 ? 0 : 1;
    }
    return r;
  };
  {
    test::Run run(chart_grid(strips));
    ASSERT_EQ(run.ctx.atlas.num_charts, 3);
    ArapSolver solver;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions(run.mesh), o, solver, {});
    EXPECT_EQ(r.rejected.count("seam_too_short"), 0u);
    EXPECT_EQ(r.accepted, 1u);
    EXPECT_EQ(r.charts_out, 2u);
    test::expect_valid_atlas(run);
  }
  // The same strips among one chart per remaining quad: A and B have more than 5 neighbours, so no
  // short lookahead applies and the A-B seam is refused.
  {
    test::Run run(chart_grid([&](int i, int j) { return strips(i, j) < 2 ? strips(i, j) : 2 + j * 8 + i; }));
    ASSERT_EQ(run.ctx.atlas.num_charts, 2 + 18);
    ArapSolver solver;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions(run.mesh), o, solver, {});
    ASSERT_EQ(r.rejected.count("seam_too_short"), 1u);
    EXPECT_GE(r.rejected.at("seam_too_short"), 1u);
    int a = run.ctx.atlas.face_chart[2 * (8 + 1)], b = run.ctx.atlas.face_chart[2 * (8 + 4)];
    EXPECT_NE(a, b);  // quads (1, 1) and (4, 1): still apart
  }
}

TEST(MergeEngine, MinSingularValueRejectsCollapsedTriangles) {
  // Merging the distorted grid has to reshape triangles; with min_singular_value 0.9 every merge
  // that compresses a triangle below 0.9 of its input size in some direction is rolled back
  // ("collapse"), so every face of the result keeps s2 >= 0.9 (0.89 without it), while without it some do not.
  for (double bound : {0.0, 0.9}) {
    test::Run run(test::distorted_fragmented_grid(6, 5, 0.08));
    MergeOptions o;
    o.min_singular_value = bound;
    ArapSolver solver;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, o, solver, {});
    const double smin = test::smallest_singular_value(run);
    std::printf("  min_singular_value %.2f: smin %.4f, charts %zu -> %zu, collapse rejections %zu\n", bound, smin,
                r.charts_in, r.charts_out, r.rejected.count("collapse") ? r.rejected.at("collapse") : size_t{0});
    if (bound > 0) {
      EXPECT_GE(smin, bound - 1e-12);
      ASSERT_EQ(r.rejected.count("collapse"), 1u);
      EXPECT_GT(r.rejected.at("collapse"), 0u);
    } else {
      EXPECT_LT(smin, 0.9);
      EXPECT_EQ(r.rejected.count("collapse"), 0u);
    }
    EXPECT_LT(r.charts_out, r.charts_in);
  }
}

TEST(MergeEngine, MaxMergesStops) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(4, 4, 1024, "unused.png"));
  MergeOptions o;
  o.max_merges = 5;
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, o, solver, {});
  EXPECT_EQ(r.accepted, 5u);
  EXPECT_EQ(r.charts_out, 32u - 5u);
}

/// Region per face of a grid: four bands along x (the first pass's lanes).
std::vector<int> x_bands(const TexturedMesh& m, double width) {
  std::vector<int> r(m.faces.size());
  for (size_t f = 0; f < m.faces.size(); ++f) {
    const double cx = (m.corner_position(f, 0).x() + m.corner_position(f, 1).x() + m.corner_position(f, 2).x()) / 3;
    r[f] = std::min(3, static_cast<int>(cx / width));
  }
  return r;
}

TEST(MergeEngine, RegionLanesGiveTheSameAtlasForAnyThreadCount) {
  // Four regions = four first-pass lanes, run side by side with 3 threads and one after the other
  // with 1: the atlas must be the same bit for bit, with the global check after the pass (bound
  // 0.025) and with per-region budget shares (a bound the first pass overspends).
  for (double bound : {0.025, 0.002}) {
    std::vector<Atlas> out;
    std::vector<MergeReport> reps;
    for (int threads : {1, 3}) {
      set_thread_count(threads);
      test::Run run(test::distorted_fragmented_grid(8, 6, 0.08));
      MergeOptions o;
      o.priority = Priority::MMethod;
      o.global_bound = bound;
      o.second_pass = SecondPass::AcrossRegions;
      ArapSolver solver;
      reps.push_back(run_merges(run.mesh, run.topo, run.ctx.atlas, x_bands(run.mesh, 2.0), o, solver, {}));
      out.push_back(run.ctx.atlas);
      test::expect_valid_atlas(run);
    }
    set_thread_count(0);
    EXPECT_EQ(reps[0].first_pass_lanes, 4u);
    EXPECT_EQ(reps[0].first_pass_budget_shares, bound < 0.01) << "bound " << bound;
    EXPECT_EQ(reps[1].first_pass_budget_shares, reps[0].first_pass_budget_shares);
    EXPECT_LE(reps[0].distortion_out, bound * (1 + 1e-9));
    EXPECT_GT(reps[0].accepted, 10u);
    EXPECT_EQ(reps[0].accepted, reps[1].accepted);
    test::expect_same_atlas(out[0], out[1], "bound " + std::to_string(bound));
  }
}

/// Region per face of a grid: squares of side `side` (cells), so that most merges are left to the
/// second pass (across regions).
std::vector<int> squares(const TexturedMesh& m, double side) {
  std::vector<int> r(m.faces.size());
  for (size_t f = 0; f < m.faces.size(); ++f) {
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) c += m.corner_position(f, k) / 3;
    r[f] = static_cast<int>(c.x() / side) + 1000 * static_cast<int>(c.y() / side);
  }
  // Dense ids, in order of first face.
  std::map<int, int> ids;
  for (int& x : r) x = ids.emplace(x, static_cast<int>(ids.size())).first->second;
  return r;
}

/// A run with speculation against the serial one: the same counters and the same atlas bit for bit.
void expect_same_run(const Atlas& got, const MergeReport& got_rep, const Atlas& want, const MergeReport& want_rep,
                     const std::string& what) {
  EXPECT_EQ(got_rep.accepted, want_rep.accepted) << what;
  EXPECT_EQ(got_rep.attempted, want_rep.attempted) << what;
  EXPECT_EQ(got_rep.rejected, want_rep.rejected) << what;
  test::expect_same_atlas(got, want, what);
}

TEST(MergeEngine, SpeculativeSecondPassGivesTheSerialAtlas) {
  // The second pass evaluates queue entries ahead of their turn, side by side, and uses a result
  // only when the serial order reaches it (docs/mergers.md, "Parallel second pass"). The atlas must
  // be the one of one move at a time, bit for bit: batches of 1 (serial), 2 and 4 entries, on 1 and
  // 4 threads; with a budget the second pass does not reach and one it spends (refusals as
  // global_distortion, decided when a speculation is used), and in two steps.
  struct Case {
    double bound;
    int steps;
  };
  for (const Case& cs : {Case{0.025, 1}, Case{0.006, 1}, Case{0.025, 2}}) {
    std::vector<Atlas> out;
    std::vector<MergeReport> reps;
    const std::vector<std::pair<int, int>> runs{{1, 1}, {1, 2}, {1, 4}, {4, 2}, {4, 4}};  // threads, batch
    for (const auto& [threads, batch] : runs) {
      set_thread_count(threads);
      test::Run run(test::distorted_fragmented_grid(20, 16, 0.08));
      MergeOptions o;
      o.priority = Priority::MMethod;
      o.global_bound = cs.bound;
      o.second_pass = SecondPass::AcrossRegions;
      o.second_pass_seam_refusal = false;
      o.second_pass_local_bound = 0.1;
      o.second_pass_steps = cs.steps;
      o.second_pass_batch = batch;
      ArapSolver solver;
      reps.push_back(run_merges(run.mesh, run.topo, run.ctx.atlas, squares(run.mesh, 2.0), o, solver, {}));
      out.push_back(run.ctx.atlas);
      test::expect_valid_atlas(run);
    }
    set_thread_count(0);
    const std::string what = "bound " + std::to_string(cs.bound) + " steps " + std::to_string(cs.steps);
    EXPECT_GT(reps[0].accepted_second_pass, 20u) << what;
    EXPECT_EQ(reps[0].second_pass_speculated, 0u) << what;
    if (cs.bound < 0.01) {
      EXPECT_GT(reps[0].rejected["global_distortion"], 0u) << what;
    }
    for (size_t i = 1; i < runs.size(); ++i) {
      const std::string run = what + ", threads " + std::to_string(runs[i].first) + " batch " + std::to_string(runs[i].second);
      EXPECT_GT(reps[i].second_pass_speculation_used, 10u) << run;
      expect_same_run(out[i], reps[i], out[0], reps[0], run);
    }
    std::printf("%s: second pass %zu merges, speculated %zu/%zu/%zu/%zu, used %zu/%zu/%zu/%zu, global refusals %zu\n",
                what.c_str(), reps[0].accepted_second_pass, reps[1].second_pass_speculated, reps[2].second_pass_speculated,
                reps[3].second_pass_speculated, reps[4].second_pass_speculated, reps[1].second_pass_speculation_used,
                reps[2].second_pass_speculation_used, reps[3].second_pass_speculation_used,
                reps[4].second_pass_speculation_used, reps[0].rejected["global_distortion"]);
  }
}

TEST(MergeEngine, SpeculativeFirstPassWithoutRegionsGivesTheSerialAtlas) {
  // Without regions the first pass is one queue with the global check; with first_pass_speculation
  // it evaluates entries ahead of their turn side by side as the second pass does (the unconstrained
  // trial run alone). The atlas must be the serial one bit for bit: batches of 1, 2 and 4 on 1 and 4
  // threads, with a budget the pass does not reach and one it spends (global_distortion refusals).
  // note: 80 x 16 squares, not the second pass test's 20 x 16: on the smaller grid the look-ahead's
  // guesses are almost never the entries the queue pops next (1 of 163 used).
  for (double bound : {0.025, 0.006}) {
    std::vector<Atlas> out;
    std::vector<MergeReport> reps;
    const std::vector<std::pair<int, int>> runs{{1, 1}, {1, 2}, {1, 4}, {4, 2}, {4, 4}};  // threads, batch
    for (const auto& [threads, batch] : runs) {
      set_thread_count(threads);
      test::Run run(test::distorted_fragmented_grid(80, 16, 0.08));
      MergeOptions o;
      o.priority = Priority::MMethod;
      o.global_bound = bound;
      o.first_pass_speculation = batch > 1;
      o.second_pass_batch = batch;
      ArapSolver solver;
      reps.push_back(run_merges(run.mesh, run.topo, run.ctx.atlas, {}, o, solver, {}));
      out.push_back(run.ctx.atlas);
      test::expect_valid_atlas(run);
    }
    set_thread_count(0);
    const std::string what = "bound " + std::to_string(bound);
    EXPECT_GT(reps[0].accepted, 100u) << what;
    EXPECT_EQ(reps[0].first_pass_speculated, 0u) << what;
    if (bound < 0.01) {
      EXPECT_GT(reps[0].rejected["global_distortion"], 0u) << what;
    }
    for (size_t i = 1; i < runs.size(); ++i) {
      const std::string run = what + ", threads " + std::to_string(runs[i].first) + " batch " + std::to_string(runs[i].second);
      EXPECT_GT(reps[i].first_pass_speculation_used, 50u) << run;
      expect_same_run(out[i], reps[i], out[0], reps[0], run);
    }
  }
}

TEST(MergeEngine, FirstPassSpeculationStartedByAFlagGivesTheSerialAtlas) {
  // The unconstrained trial beside the run with regions starts speculating when that run ends
  // (Engine::speculate_when): whether the flag is set before the run, never, or in the middle of the
  // first pass (here by the progress callback, called every 256 queue entries), the atlas and the
  // counters are the serial ones.
  set_thread_count(2);
  const std::vector<int> no_regions;
  struct Out {
    Atlas atlas;
    MergeReport rep;
  };
  const auto run_with = [&](int mode) {  // 0: flag never set, 1: set before, 2: set at 30% progress
    test::Run run(test::distorted_fragmented_grid(80, 16, 0.08));
    MergeOptions o;
    o.priority = Priority::MMethod;
    std::atomic<bool> flag{mode == 1};
    ArapSolver solver;
    detail::Engine e(run.mesh, run.topo, run.ctx.atlas, no_regions, o, solver);
    e.speculate_when(&flag);
    Out out;
    out.rep = e.run([&](double f) {
      if (mode == 2 && f > 0.3) flag = true;
    });
    out.atlas = run.ctx.atlas;
    return out;
  };
  const Out never = run_with(0), before = run_with(1), during = run_with(2);
  set_thread_count(0);
  EXPECT_EQ(never.rep.first_pass_speculated, 0u);
  EXPECT_GT(before.rep.first_pass_speculation_used, 50u);
  EXPECT_GT(during.rep.first_pass_speculation_used, 10u);
  EXPECT_LT(during.rep.first_pass_speculated, before.rep.first_pass_speculated);
  expect_same_run(before.atlas, before.rep, never.atlas, never.rep, "flag set before");
  expect_same_run(during.atlas, during.rep, never.atlas, never.rep, "flag set mid-pass");
}

/// ARAP, except that every problem with a number of triangles divisible by 3 "needs the repair": it
/// is refused (inverted) when the caller cannot use a repair, else returned as repaired. Counts the
/// repairs it ran (any thread).
class RepairingSolver final : public LocalSolver {
 public:
  SolveResult solve(LocalProblem& p) override {
    SolveResult r = arap_.solve(p);
    if (!r.ok || p.tri.size() % 3 != 0) return r;
    if (!p.repair_usable) {
      r.ok = false;
      r.failure = "inverted triangles after ARAP";
      return r;
    }
    r.repaired = true;
    ++repairs_run;
    return r;
  }
  bool reentrant() const override { return true; }
  std::atomic<size_t> repairs_run{0};

 private:
  ArapSolver arap_;
};

TEST(MergeEngine, SpeculationSkipsTheRepairsTheSerialPassSkips) {
  // Once the main lane has spent repaired_global_share of the budget, its solves skip the
  // injectivity repair (refused as flips). Speculations evaluated then skip it as well (their lanes'
  // repair_off); one whose entry comes after the error sum fell back under the share is evaluated
  // again. The atlas and the counters must be the serial ones, and the repairs run side by side at
  // most the serial pass's plus one per speculation not used (without repair_off, every move drain
  // evaluates while the share is spent would run one more).
  for (double share : {1.0, 0.3}) {
    std::vector<Atlas> out;
    std::vector<MergeReport> reps;
    std::vector<size_t> run_repairs;
    for (int batch : {1, 4}) {
      set_thread_count(batch == 1 ? 1 : 2);
      test::Run run(test::distorted_fragmented_grid(20, 16, 0.08));
      MergeOptions o;
      o.priority = Priority::MMethod;
      o.global_bound = 0.006;
      o.repaired_global_share = share;
      o.second_pass = SecondPass::AcrossRegions;
      o.second_pass_seam_refusal = false;
      o.second_pass_local_bound = 0.1;
      o.second_pass_batch = batch;
      RepairingSolver solver;
      reps.push_back(run_merges(run.mesh, run.topo, run.ctx.atlas, squares(run.mesh, 2.0), o, solver, {}));
      run_repairs.push_back(solver.repairs_run);
      out.push_back(run.ctx.atlas);
    }
    set_thread_count(0);
    const std::string what = "share " + std::to_string(share);
    EXPECT_GT(reps[0].repairs_tried, 5u) << what;
    if (share < 1) {
      EXPECT_GT(reps[0].rejected["flip"], 5u) << what;  // the share was spent during the pass
    }
    EXPECT_GT(reps[1].second_pass_speculation_used, 10u) << what;
    EXPECT_EQ(reps[1].repairs_tried, reps[0].repairs_tried) << what;
    EXPECT_EQ(reps[1].rejected, reps[0].rejected) << what;
    EXPECT_EQ(reps[1].accepted, reps[0].accepted) << what;
    test::expect_same_atlas(out[1], out[0], what);
    const size_t unused = reps[1].second_pass_speculated - reps[1].second_pass_speculation_used;
    EXPECT_LE(run_repairs[1], run_repairs[0] + unused) << what;
    std::printf("%s: repairs run serial %zu, side by side %zu (speculations unused %zu), flips %zu\n", what.c_str(),
                run_repairs[0], run_repairs[1], unused, reps[0].rejected["flip"]);
  }
}

TEST(MergeEngine, KeptSeamFiguresAreTheSeamsOwn) {
  // Under the M-method's order every pair of a merged chart is re-queued; a seam none of whose faces
  // changed since it was last scored is re-scored from its kept figures. With check_kept_seams each
  // re-use computes them again and throws when they differ: one region, then squares of regions with
  // the second pass (figures kept through the first pass, then dropped when it starts).
  for (bool regions : {false, true}) {
    test::Run run(test::distorted_fragmented_grid(20, 16, 0.08));
    MergeOptions o;
    o.priority = Priority::MMethod;
    o.second_pass = regions ? SecondPass::AcrossRegions : SecondPass::None;
    o.second_pass_seam_refusal = false;
    o.check_kept_seams = true;
    ArapSolver solver;
    MergeReport r;
    const std::vector<int> reg = regions ? squares(run.mesh, 4.0) : std::vector<int>{};
    ASSERT_NO_THROW(r = run_merges(run.mesh, run.topo, run.ctx.atlas, reg, o, solver, {})) << "regions " << regions;
    EXPECT_GT(r.seam_figures_kept, 100u) << "regions " << regions;
    EXPECT_GT(r.accepted, 100u) << "regions " << regions;
    std::printf("regions %d: %zu merges, %zu seams re-scored from kept figures\n", regions ? 1 : 0, r.accepted,
                r.seam_figures_kept);
  }
}

/// run_merges with the unconstrained trial on the 20 x 16 distorted grid in squares of regions: its
/// report and atlas, with `threads` threads and the trial beside or after the run with regions.
std::pair<MergeReport, Atlas> trial_run(int threads, bool beside, double share, size_t beside_max_faces = 300000) {
  set_thread_count(threads);
  test::Run run(test::distorted_fragmented_grid(20, 16, 0.08));
  MergeOptions o;
  o.priority = Priority::MMethod;
  o.unconstrained_trial = true;
  o.unconstrained_trial_share = share;
  o.unconstrained_trial_beside = beside;
  o.unconstrained_trial_beside_max_faces = beside_max_faces;
  ArapSolver solver;
  MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, squares(run.mesh, 3.0), o, solver, {});
  set_thread_count(0);
  test::expect_valid_atlas(run);
  return {r, run.ctx.atlas};
}

TEST(MergeEngine, TheTrialBesideGivesTheTrialAfter) {
  // The unconstrained trial on a thread beside the run with regions (2 threads) against the trial run
  // after it (1 thread): the same decision and atlas bit for bit, whether the trial is needed and
  // kept (with regions and no second pass the run ends far under 0.8 x the bound), or not needed (a
  // share of 0.05: dropped beside, or ended when it was quicker).
  for (double share : {0.8, 0.05}) {
    const auto [after, atlas_after] = trial_run(1, false, share);
    const auto [beside, atlas_beside] = trial_run(2, true, share);
    const std::string what = "share " + std::to_string(share);
    EXPECT_EQ(after.unconstrained_trial_beside, "off") << what;
    EXPECT_EQ(after.unconstrained_trial_run, share > 0.5) << what << " E " << after.distortion_out;
    EXPECT_EQ(beside.unconstrained_trial_run, after.unconstrained_trial_run) << what;
    EXPECT_EQ(beside.unconstrained_trial_kept, after.unconstrained_trial_kept) << what;
    if (share > 0.5) {
      EXPECT_TRUE(after.unconstrained_trial_kept) << what;
      EXPECT_EQ(beside.unconstrained_trial_beside, "ended") << what;
    } else {
      EXPECT_NE(beside.unconstrained_trial_beside, "off") << what;
    }
    std::printf("%s: trial run %d, kept %d, beside %s\n", what.c_str(), after.unconstrained_trial_run ? 1 : 0,
                after.unconstrained_trial_kept ? 1 : 0, beside.unconstrained_trial_beside.c_str());
    EXPECT_EQ(beside.accepted, after.accepted) << what;
    EXPECT_EQ(beside.seam_left_length_3d(), after.seam_left_length_3d()) << what;
    test::expect_same_atlas(atlas_beside, atlas_after, what);
  }
}

TEST(MergeEngine, ACancelledRunThrowsAtItsFirstStep) {
  test::Run run(test::distorted_fragmented_grid(4, 4, 0.08));
  ArapSolver solver;
  const std::atomic<bool> cancel{true};
  const std::vector<int> no_regions;  // (the engine keeps a reference)
  detail::Engine e(run.mesh, run.topo, run.ctx.atlas, no_regions, MergeOptions{}, solver);
  e.cancel_when(&cancel);
  EXPECT_THROW(e.run({}), detail::Engine::Cancelled);
}

TEST(MergeEngine, RegionsOfTheWrongSizeAreAnError) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(2, 2, 1024, "unused.png"));
  ArapSolver solver;
  EXPECT_THROW(run_merges(run.mesh, run.topo, run.ctx.atlas, std::vector<int>(3, 0), MergeOptions{}, solver, {}),
               std::invalid_argument);
}

TEST(MergeEngine, AModelAboveTheBesideLimitRunsTheTrialAfter) {
  // The 20 x 16 grid has 640 faces: with the limit at 639 the trial runs after the run with regions
  // even on two threads ("off"), at 640 it runs beside ("ended"); both give the same atlas.
  const auto [over, atlas_over] = trial_run(2, true, 0.8, 639);
  const auto [at, atlas_at] = trial_run(2, true, 0.8, 640);
  EXPECT_EQ(over.unconstrained_trial_beside, "off");
  EXPECT_EQ(at.unconstrained_trial_beside, "ended");
  EXPECT_TRUE(over.unconstrained_trial_kept);
  EXPECT_EQ(over.unconstrained_trial_kept, at.unconstrained_trial_kept);
  EXPECT_EQ(atlas_over.face_chart, atlas_at.face_chart);
  EXPECT_EQ(atlas_over.face_wedge, atlas_at.face_wedge);
  EXPECT_TRUE(atlas_over.wedge_uv == atlas_at.wedge_uv);
}

}  // namespace
}  // namespace texdefrag::merge

