// mergers.arap (the M-method's optimiser): both ARAP solvers (Eigen local/global, Ceres LM) on
// hand-checkable local problems, then the stage created by name on hand-built meshes with each.
#include "arap_solver.h"
#include "ceres_arap_solver.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>

namespace texdefrag::merge {
namespace {

// ---- the solvers on local problems ----------------------------------------------------------

/// A solver by name with the given iteration cap and tolerance.
std::unique_ptr<LocalSolver> make_solver(const std::string& name, int iterations, double tolerance) {
  if (name == "ceres") {
    CeresArapSettings s;
    s.iterations = iterations;
    s.tolerance = tolerance;
    return std::make_unique<CeresArapSolver>(s);
  }
  ArapSettings s;
  s.iterations = iterations;
  s.tolerance = tolerance;
  return std::make_unique<ArapSolver>(s);
}

/// Sets p's rest shapes (rest_inv, weight = rest area) from rest positions (indexed like p.x).
void set_rest(LocalProblem& p, const std::vector<Vec2>& rest) {
  p.rest_inv.clear();
  p.weight.clear();
  for (const auto& t : p.tri) {
    Mat2 Dm;
    Dm.col(0) = rest[static_cast<size_t>(t[1])] - rest[static_cast<size_t>(t[0])];
    Dm.col(1) = rest[static_cast<size_t>(t[2])] - rest[static_cast<size_t>(t[0])];
    p.rest_inv.push_back(Dm.inverse());
    p.weight.push_back(0.5 * Dm.determinant());
  }
}

/// An n-by-n vertex grid, spacing 10 texels, jittered by up to 2 texels (fixed formula), 2 CCW
/// triangles per cell; interior vertices free (first in x), boundary ones pinned. `rest` receives
/// the rest positions; x is left equal to them.
LocalProblem jittered_grid(int n, std::vector<Vec2>& rest) {
  LocalProblem p;
  std::vector<int> id(static_cast<size_t>(n * n));
  auto interior = [n](int i, int j) { return i > 0 && j > 0 && i < n - 1 && j < n - 1; };
  auto pos = [](int i, int j) {
    return Vec2(10.0 * i + 2.0 * std::sin(12.9898 * i + 78.233 * j), 10.0 * j + 2.0 * std::cos(39.346 * i + 11.135 * j));
  };
  for (int pass = 0; pass < 2; ++pass)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (interior(i, j) == (pass == 0)) {
          id[static_cast<size_t>(j * n + i)] = static_cast<int>(p.x.size());
          p.x.push_back(pos(i, j));
        }
  p.num_free = (n - 2) * (n - 2);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = id[static_cast<size_t>(j * n + i)], b = id[static_cast<size_t>(j * n + i + 1)];
      const int c = id[static_cast<size_t>((j + 1) * n + i + 1)], d = id[static_cast<size_t>((j + 1) * n + i)];
      p.tri.push_back({a, b, c});
      p.tri.push_back({a, c, d});
    }
  rest = p.x;
  set_rest(p, rest);
  return p;
}

TEST(ArapResidual, JacobianMatchesFiniteDifferences) {
  for (const Mat2& F : {Mat2{{1.2, 0.3}, {-0.4, 0.9}}, Mat2{{0.2, -1.1}, {0.8, 0.1}}, Mat2{{-0.7, 0.2}, {0.1, 0.5}},
                        Mat2{{1.0, 0.0}, {0.0, 1.0}}}) {
    Eigen::Vector4d r;
    Eigen::Matrix4d J;
    arap_residual(F, r, J);
    const Mat2 R = closest_rotation(F);
    EXPECT_NEAR(r[1], F(0, 1) - R(0, 1), 1e-15);
    EXPECT_NEAR(r.squaredNorm(), (F - R).squaredNorm(), 1e-14);
    const double h = 1e-6;
    for (int c = 0; c < 4; ++c) {
      Mat2 Fp = F, Fm = F;
      Fp(c / 2, c % 2) += h;
      Fm(c / 2, c % 2) -= h;
      Eigen::Vector4d rp, rm;
      Eigen::Matrix4d unused;
      arap_residual(Fp, rp, unused);
      arap_residual(Fm, rm, unused);
      const Eigen::Vector4d fd = (rp - rm) / (2 * h);
      for (int i = 0; i < 4; ++i) EXPECT_NEAR(J(i, c), fd[i], 1e-7) << "F=\n" << F << "\nrow " << i << " col " << c;
    }
  }
}

class ArapSolvers : public ::testing::TestWithParam<std::string> {};

// Rest (0,0), (1,0), (0.5, h); base pinned at (0,0), (s,0). By symmetry F = diag(s, y/h) at the
// optimum, whose closest rotation is I, so the energy (s-1)^2 + (y/h-1)^2 is least at apex
// (s/2, h) with energy (s-1)^2.
TEST_P(ArapSolvers, StretchedBaseTriangleByHand) {
  const double h = 0.8, s = 1.5;
  LocalProblem p;
  p.x = {{0.9, 0.3}, {0, 0}, {s, 0}};  // apex free, displaced
  p.num_free = 1;
  p.tri = {{1, 2, 0}};
  set_rest(p, {{0.5, h}, {0, 0}, {1, 0}});
  const SolveResult r = make_solver(GetParam(), 200, 1e-15)->solve(p);
  EXPECT_TRUE(r.ok) << r.failure;
  EXPECT_NEAR(p.x[0].x(), s / 2, 1e-6);
  EXPECT_NEAR(p.x[0].y(), h, 1e-6);
  EXPECT_NEAR(r.energy, (s - 1) * (s - 1), 1e-9);
  EXPECT_EQ(p.x[1], Vec2(0, 0));
  EXPECT_EQ(p.x[2], Vec2(s, 0));
}

// Boundary pinned at 1.1 x its rest positions: F = 1.1 I on every triangle is stationary (the
// interior vertices' gradient sums of a constant field vanish), so the interior goes to 1.1 x rest
// and the energy is 2 * 0.1^2 = 0.02 whatever the triangle shapes.
TEST_P(ArapSolvers, PinnedScaledBoundaryByHand) {
  std::vector<Vec2> rest;
  LocalProblem p = jittered_grid(6, rest);
  for (size_t i = 0; i < p.x.size(); ++i) p.x[i] = 1.1 * rest[i];
  for (int i = 0; i < p.num_free; ++i) p.x[static_cast<size_t>(i)] += Vec2(1.5 * std::sin(i), 1.5 * std::cos(3 * i));
  const std::vector<Vec2> start = p.x;
  const SolveResult r = make_solver(GetParam(), 500, 1e-15)->solve(p);
  EXPECT_TRUE(r.ok) << r.failure;
  for (int i = 0; i < p.num_free; ++i) EXPECT_NEAR((p.x[static_cast<size_t>(i)] - 1.1 * rest[static_cast<size_t>(i)]).norm(), 0, 1e-5) << i;
  for (size_t i = static_cast<size_t>(p.num_free); i < p.x.size(); ++i) EXPECT_EQ(p.x[i], start[i]) << "pinned " << i;
  EXPECT_NEAR(r.energy, 0.02, 1e-9);
  EXPECT_NEAR(arap_energy(p), r.energy, 1e-15);
}

TEST_P(ArapSolvers, RestoresTheRestShape) {
  std::vector<Vec2> rest;
  LocalProblem p = jittered_grid(7, rest);
  for (int i = 0; i < p.num_free; ++i) p.x[static_cast<size_t>(i)] += Vec2(2 * std::cos(5 * i), 2 * std::sin(2 * i));
  EXPECT_GT(arap_energy(p), 1e-3);
  const SolveResult r = make_solver(GetParam(), 500, 1e-15)->solve(p);
  EXPECT_TRUE(r.ok) << r.failure;
  for (int i = 0; i < p.num_free; ++i) EXPECT_NEAR((p.x[static_cast<size_t>(i)] - rest[static_cast<size_t>(i)]).norm(), 0, 1e-5);
  EXPECT_LT(r.energy, 1e-12);
}

TEST_P(ArapSolvers, UntanglesAnInvertedStart) {
  std::vector<Vec2> rest;
  LocalProblem p = jittered_grid(4, rest);  // 4 free interior vertices
  p.x[0] = p.x[3] + Vec2(4, 3);            // first interior vertex pushed past its diagonal neighbour
  ASSERT_GT(count_inverted(p), 0);
  const SolveResult r = make_solver(GetParam(), 10, 1e-6)->solve(p);
  EXPECT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(count_inverted(p), 0);
}

// Acceptance: an inverted triangle the solver cannot move is reported, with and without free ones.
TEST_P(ArapSolvers, ReportsInvertedTrianglesItCannotFix) {
  std::vector<Vec2> rest;
  LocalProblem p = jittered_grid(4, rest);
  // An extra triangle on three pinned corners, given a rest shape of the opposite orientation.
  const int a = p.num_free, b = p.num_free + 1, c = p.num_free + 2;
  p.tri.push_back({a, c, b});
  p.rest_inv.push_back(Mat2::Identity());
  p.weight.push_back(1);
  {
    Mat2 Dm;
    Dm.col(0) = rest[static_cast<size_t>(b)] - rest[static_cast<size_t>(a)];
    Dm.col(1) = rest[static_cast<size_t>(c)] - rest[static_cast<size_t>(a)];
    p.rest_inv.back() = Dm.inverse();  // rest = (a, b, c) CCW, current corners (a, c, b): inverted
  }
  ASSERT_EQ(count_inverted(p), 1);
  LocalProblem q = p;
  SolveResult r = make_solver(GetParam(), 10, 1e-6)->solve(p);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.failure.empty());
  q.num_free = 0;
  const std::vector<Vec2> start = q.x;
  r = make_solver(GetParam(), 10, 1e-6)->solve(q);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.failure.empty());
  EXPECT_EQ(q.x, start);  // nothing free: nothing moved
}

// The injectivity repair on a fan checked by hand: one free vertex c joined to a pinned pentagon
// with a notch, P0 (0,0), P1 (4,0), P2 (4,4), P3 (2,1), P4 (0,4) (counter-clockwise). c sees every
// edge, i.e. no fan triangle (c, Pi, Pi+1) is inverted, exactly inside the triangle (4/3,0), (8/3,0),
// (2,1) under the notch (left of P2->P3: 3x - 2y > 4; left of P3->P4: 3x + 2y < 8; y > 0). The rest
// shapes are the fan of a regular pentagon of radius 2 around its centre, which pulls c to the middle
// of the polygon, above the notch: plain local/global steps end with triangles (c, P2, P3) and
// (c, P3, P4) inverted, the repair moves c under the notch.
LocalProblem notched_fan() {
  LocalProblem p;
  p.x = {Vec2(2, 2.5), Vec2(0, 0), Vec2(4, 0), Vec2(4, 4), Vec2(2, 1), Vec2(0, 4)};
  p.num_free = 1;
  std::vector<Vec2> rest{Vec2(0, 0)};
  for (int i = 0; i < 5; ++i) {
    const double a = -1.5 * 3.141592653589793 / 2 + 2 * 3.141592653589793 * i / 5;  // P0 at bottom left
    rest.emplace_back(2 * std::cos(a), 2 * std::sin(a));
  }
  for (int i = 0; i < 5; ++i) p.tri.push_back({0, 1 + i, 1 + (i + 1) % 5});
  set_rest(p, rest);
  return p;
}

TEST(ArapRepair, PlainStepsLeaveTheNotchedFanInverted) {
  LocalProblem p = notched_fan();
  const SolveResult r = make_solver("eigen", 10, 1e-6)->solve(p);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.repaired);
  EXPECT_GT(count_inverted(p), 0);
  EXPECT_GT(p.x[0].y(), 1.0);  // above the notch
}

TEST(ArapRepair, UntangleMovesTheFreeVertexUnderTheNotch) {
  LocalProblem p = notched_fan();
  ArapSettings s;
  s.untangle = true;
  const std::vector<Vec2> pinned(p.x.begin() + 1, p.x.end());
  const SolveResult r = ArapSolver(s).solve(p);
  EXPECT_TRUE(r.ok) << r.failure;
  EXPECT_TRUE(r.repaired);
  EXPECT_EQ(count_inverted(p), 0);
  const Vec2 c = p.x[0];
  EXPECT_GT(3 * c.x() - 2 * c.y(), 4);
  EXPECT_LT(3 * c.x() + 2 * c.y(), 8);
  EXPECT_GT(c.y(), 0);
  EXPECT_EQ(std::vector<Vec2>(p.x.begin() + 1, p.x.end()), pinned);  // pinned corners untouched
  // The energy reported is the final one, and the flip-free steps never went above the untangled start.
  EXPECT_NEAR(r.energy, arap_energy(p), 1e-12);
}

TEST(ArapRepair, FlipFreeStepsKeepTheSingularValueFloor) {
  // With a floor, no triangle whose smaller singular value was at least the floor after untangling
  // goes below it during the flip-free steps.
  LocalProblem p = notched_fan();
  ArapSettings s;
  s.untangle = true;
  s.singular_value_floor = 0.2;
  LocalProblem q = p;
  ASSERT_TRUE(untangle(q));
  std::vector<double> before;
  for (size_t t = 0; t < q.tri.size(); ++t) before.push_back(signed_singular_values_2x2(deformation_gradient(q, t))[1]);
  const SolveResult r = ArapSolver(s).solve(p);
  ASSERT_TRUE(r.ok) << r.failure;
  for (size_t t = 0; t < p.tri.size(); ++t)
    if (before[t] >= 0.2) {
      EXPECT_GE(signed_singular_values_2x2(deformation_gradient(p, t))[1], 0.2) << t;
    }
}

TEST(ArapRepair, ShapeKeptNeedsAPositiveDeterminantAndTheFloor) {
  EXPECT_TRUE(shape_kept(Mat2::Identity(), 0.2));
  const Mat2 squeezed = Eigen::Vector2d(1, 0.1).asDiagonal();  // singular values 1 and 0.1
  EXPECT_FALSE(shape_kept(squeezed, 0.2));
  EXPECT_TRUE(shape_kept(squeezed, 0.05));
  const Mat2 mirror = Eigen::Vector2d(1, -1).asDiagonal();  // det -1: never kept, whatever the floor
  EXPECT_FALSE(shape_kept(mirror, -5));
  EXPECT_FALSE(shape_kept(Mat2::Zero(), -1));  // collapsed: det 0
  const double c = std::cos(0.5), s = std::sin(0.5);
  Mat2 turned;  // half-size rotation: both singular values 0.5
  turned << 0.5 * c, -0.5 * s, 0.5 * s, 0.5 * c;
  EXPECT_TRUE(shape_kept(turned, 0.49));
  EXPECT_FALSE(shape_kept(turned, 0.51));
}

/// A pinned 2 x 2 square (0,0), (2,0), (2,2), (0,2) around one free centre vertex whose rest position
/// is the middle (1,1), started at (3,1) outside the square: triangle (c, P1, P2) is inverted.
LocalProblem square_with_centre_outside() {
  LocalProblem p;
  p.x = {Vec2(3, 1), Vec2(0, 0), Vec2(2, 0), Vec2(2, 2), Vec2(0, 2)};
  p.num_free = 1;
  for (int i = 0; i < 4; ++i) p.tri.push_back({0, 1 + i, 1 + (i + 1) % 4});
  set_rest(p, {Vec2(1, 1), Vec2(0, 0), Vec2(2, 0), Vec2(2, 2), Vec2(0, 2)});
  return p;
}

TEST(ArapRepair, UntangleStopsOnceEveryShapeKeepsTheFloor) {
  LocalProblem full = square_with_centre_outside(), stopped = full, unreachable = full;
  ASSERT_TRUE(untangle(full));
  UntangleSettings s;
  s.stop_floor = 0.2;
  ASSERT_TRUE(untangle(stopped, s));
  for (size_t t = 0; t < stopped.tri.size(); ++t) EXPECT_TRUE(shape_kept(deformation_gradient(stopped, t), 0.2)) << t;
  // The full minimisation goes on towards the rest position; the stop is somewhere before it.
  EXPECT_NEAR(full.x[0].x(), 1, 1e-3);
  EXPECT_NEAR(full.x[0].y(), 1, 1e-3);
  EXPECT_GT((stopped.x[0] - full.x[0]).norm(), 1e-6);
  // A floor no triangle reaches never stops it: the same bits as without one.
  s.stop_floor = 10;
  ASSERT_TRUE(untangle(unreachable, s));
  EXPECT_EQ(unreachable.x, full.x);
}

/// A free centre vertex inside a pinned 24-gon of radius 2 listed clockwise, against the rest shape of
/// the counter-clockwise fan: the fan's signed areas add up to the polygon's, negative wherever the
/// centre goes, so at least one triangle stays inverted (no untangling exists) and, from the centre,
/// all 24 are.
LocalProblem clockwise_ring() {
  LocalProblem p;
  constexpr int kSides = 24;
  std::vector<Vec2> rest{Vec2(0, 0)};
  p.x = {Vec2(0, 0)};
  for (int i = 0; i < kSides; ++i) {
    const double a = 2 * 3.141592653589793 * i / kSides;
    rest.emplace_back(2 * std::cos(a), 2 * std::sin(a));
    p.x.emplace_back(2 * std::cos(a), -2 * std::sin(a));  // mirrored: clockwise
  }
  p.num_free = 1;
  for (int i = 0; i < kSides; ++i) p.tri.push_back({0, 1 + i, 1 + (i + 1) % kSides});
  set_rest(p, rest);
  return p;
}

TEST(ArapRepair, UntangleGivesUpWhenTheInvertedCountStalls) {
  LocalProblem stalled = clockwise_ring(), patient = stalled;
  ASSERT_EQ(count_inverted(stalled), 24);
  const std::vector<Vec2> start = stalled.x;
  UntangleReport quick, full;
  EXPECT_FALSE(untangle(stalled, UntangleSettings{}, &quick));
  UntangleSettings never;
  never.stall.reset();
  EXPECT_FALSE(untangle(patient, never, &full));
  EXPECT_EQ(full.rounds, never.outer_iterations);
  EXPECT_GE(quick.rounds, UntangleStall{}.rounds + 1);  // needs rounds + 1 counts to compare
  EXPECT_LT(quick.rounds, full.rounds);
  EXPECT_LT(quick.lbfgs_steps, full.lbfgs_steps);
  EXPECT_EQ(stalled.x, start);  // given up: positions as given, as after all 20 rounds
  EXPECT_EQ(patient.x, start);
}

TEST(ArapRepair, UntangleReportsItsRoundsAndSteps) {
  LocalProblem p = notched_fan();
  UntangleReport r;
  ASSERT_TRUE(untangle(p, UntangleSettings{}, &r));
  EXPECT_GE(r.rounds, 1);
  EXPECT_GE(r.lbfgs_steps, 1);
  LocalProblem fine = notched_fan();
  fine.x[0] = Vec2(2, 0.5);  // nothing inverted: nothing to do
  ASSERT_TRUE(untangle(fine, UntangleSettings{}, &r));
  EXPECT_EQ(r.rounds, 0);
  EXPECT_EQ(r.lbfgs_steps, 0);
}

TEST(ArapRepair, UntangleRefusesAnInvertedTriangleWithoutFreeCorner) {
  LocalProblem p = notched_fan();
  p.x[0] = Vec2(2, 0.5);  // valid fan
  p.tri.push_back({1, 3, 2});  // P0, P2, P1: clockwise, all pinned
  p.rest_inv.push_back(Mat2::Identity());
  p.weight.push_back(1);
  const std::vector<Vec2> start = p.x;
  EXPECT_FALSE(untangle(p));
  EXPECT_EQ(p.x, start);
}

INSTANTIATE_TEST_SUITE_P(Both, ArapSolvers, ::testing::Values("eigen", "ceres"),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param; });

// Both solvers reach the same minimum of the same energy on a bent, jittered patch.
TEST(ArapSolversAgree, SameMinimumOnABentPatch) {
  std::vector<Vec2> rest;
  LocalProblem p = jittered_grid(8, rest);
  // Pinned boundary (and interior start) under a smooth non-rigid map.
  for (size_t i = 0; i < p.x.size(); ++i) {
    const Vec2 q = rest[i];
    p.x[i] = Vec2(1.05 * q.x() + 0.004 * q.y() * q.y(), 0.93 * q.y() + 0.08 * q.x() + 3 * std::sin(q.x() / 20));
  }
  LocalProblem pe = p, pc = p;
  const SolveResult re = make_solver("eigen", 1000, 1e-15)->solve(pe);
  const SolveResult rc = make_solver("ceres", 1000, 1e-15)->solve(pc);
  ASSERT_TRUE(re.ok && rc.ok);
  EXPECT_GT(re.energy, 1e-4);  // not a trivial minimum
  EXPECT_NEAR(re.energy, rc.energy, 1e-9 * re.energy);
  for (int i = 0; i < p.num_free; ++i)
    EXPECT_NEAR((pe.x[static_cast<size_t>(i)] - pc.x[static_cast<size_t>(i)]).norm(), 0, 1e-4) << i;
}

// ---- the stage, created by name, with each solver ------------------------------------------

class Arap : public ::testing::TestWithParam<std::string> {
 protected:
  json with_solver(json o = json::object()) const {
    o["solver"] = GetParam();
    return o;
  }
};

TEST_P(Arap, FragmentedGridMergesIntoOneChart) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(8, 6, 1024, "unused.png"));
  run.merge("mergers.arap", with_solver());
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  EXPECT_LT(run.report["distortion_arap"].get<double>(), 1e-10);
  test::expect_valid_atlas(run);
}

TEST_P(Arap, MMethodPriorityMergesTheGridToo) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(8, 6, 1024, "unused.png"));
  run.merge("mergers.arap", with_solver({{"priority", "mmethod"}}));
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  test::expect_valid_atlas(run);
}

TEST_P(Arap, NeverMergesAcrossRegions) {
  std::vector<int> region;
  TexturedMesh m = test::folded_grid(6, 4, region);
  test::Run run(std::move(m), region);
  run.merge("mergers.arap", with_solver({{"priority", "mmethod"}}));
  std::vector<std::set<int>> regions_of(static_cast<size_t>(run.ctx.atlas.num_charts));
  for (size_t f = 0; f < run.mesh.faces.size(); ++f)
    regions_of[static_cast<size_t>(run.ctx.atlas.face_chart[f])].insert(run.ctx.regions.face_region[f]);
  for (const auto& s : regions_of) EXPECT_EQ(s.size(), 1u);
  // note: the M-method refuses seams under 0.2 of both charts' borders, so two blobs grown in the
  // same half may stay apart; what matters here is that no chart spans both halves.
  EXPECT_GE(run.ctx.atlas.num_charts, 2);
  EXPECT_LE(run.ctx.atlas.num_charts, 4) << run.report.dump();
}

TEST_P(Arap, LocalBoundRejectsAndRollsBack) {
  test::Run run(test::distorted_fragmented_grid(5, 4, 0.1));
  const Atlas before = run.ctx.atlas;
  run.merge("mergers.arap", with_solver({{"local_bound", 0.0}}));
  EXPECT_EQ(run.report["merges_accepted"], 0);
  EXPECT_GT(run.report["rejected"].value("local_distortion", 0), 0);
  EXPECT_EQ(run.ctx.atlas.face_wedge, before.face_wedge);
  EXPECT_EQ(run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(run.ctx.atlas.face_chart, before.face_chart);
}

TEST_P(Arap, DistortedInputStaysWithinTheBound) {
  test::Run run(test::distorted_fragmented_grid(10, 8, 0.05));
  run.merge("mergers.arap", with_solver({{"priority", "mmethod"}}));
  EXPECT_LE(run.report["distortion_arap"].get<double>(), 0.025);
  EXPECT_LT(run.ctx.atlas.num_charts, 160);
  EXPECT_GT(run.report["optimisation_seconds"].get<double>(), 0);
  test::expect_valid_atlas(run);
}

INSTANTIATE_TEST_SUITE_P(Solver, Arap, ::testing::Values("eigen", "ceres"),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param; });

TEST(ArapOptions, SolverIsAValidatedEnum) {
  Registry& r = Registry::instance();
  r.load_plugins();
  const StageInfo* info = r.find("mergers.arap");
  ASSERT_NE(info, nullptr);
  const OptionSpec* spec = nullptr;
  for (const OptionSpec& o : info->options)
    if (o.key == "solver") spec = &o;
  ASSERT_NE(spec, nullptr);
  EXPECT_EQ(spec->type, OptionType::Enum);
  EXPECT_EQ(spec->choices, (std::vector<std::string>{"eigen", "ceres"}));
  EXPECT_EQ(default_options(*info, {{"solver", "ceres"}}).get_string("solver"), "ceres");
  EXPECT_EQ(default_options(*info, {{"solver", "eigen"}}).get_string("solver"), "eigen");
  EXPECT_THROW(default_options(*info, {{"solver", "cholmod"}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"solver", "Ceres"}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"solver", 1}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"arap_iterations", 0}}), std::invalid_argument);
}

TEST(ArapOptions, UntangleNeedsTheEigenSolver) {
  Registry& r = Registry::instance();
  r.load_plugins();
  const StageInfo* info = r.find("mergers.arap");
  ASSERT_NE(info, nullptr);
  std::unique_ptr<Stage> stage = info->create();
  EXPECT_NO_THROW(stage->set_options(default_options(*info, {{"untangle", true}})));
  EXPECT_THROW(stage->set_options(default_options(*info, {{"untangle", true}, {"solver", "ceres"}})), StageError);
}

}  // namespace
}  // namespace texdefrag::merge
