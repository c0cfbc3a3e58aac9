// mergers.optcuts: the symmetric Dirichlet derivatives against finite differences, the projected
// Newton solver, and the stage (created by name) on hand-built meshes with known answers.
#include "sd_newton.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include <set>

namespace texdefrag::merge {
namespace {

Mat2 unvec(const Eigen::Vector4d& v) {
  Mat2 F;
  F << v[0], v[1], v[2], v[3];
  return F;
}

TEST(OptCutsSolver, SymmetricDirichletByHand) {
  EXPECT_NEAR(sd_energy(Mat2::Identity()), 4.0, 1e-14);
  Mat2 F;
  F << 2, 0, 0, 1;
  EXPECT_NEAR(sd_energy(F), 4 + 1 + 0.25 + 1, 1e-14);
  F << -1, 0, 0, 1;
  EXPECT_TRUE(std::isinf(sd_energy(F)));
}

TEST(OptCutsSolver, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 50; ++trial) {
    Mat2 F;
    F << 1 + u(rng), u(rng), u(rng), 1 + u(rng);
    if (F.determinant() < 0.2) continue;
    Eigen::Vector4d g;
    Eigen::Matrix4d H;
    sd_gradient_hessian(F, g, H);
    const Eigen::Vector4d f(F(0, 0), F(0, 1), F(1, 0), F(1, 1));
    const double h = 1e-6;
    Eigen::Matrix4d Hfd;
    for (int i = 0; i < 4; ++i) {
      Eigen::Vector4d e = Eigen::Vector4d::Zero();
      e[i] = h;
      const double gfd = (sd_energy(unvec(f + e)) - sd_energy(unvec(f - e))) / (2 * h);
      EXPECT_NEAR(g[i], gfd, 1e-5 * std::max(1.0, std::abs(gfd)));
      Eigen::Vector4d gp, gm;
      Eigen::Matrix4d tmp;
      sd_gradient_hessian(unvec(f + e), gp, tmp);
      sd_gradient_hessian(unvec(f - e), gm, tmp);
      Hfd.col(i) = (gp - gm) / (2 * h);
    }
    Hfd = 0.5 * (Hfd + Hfd.transpose());
    // The projection only clamps negative eigenvalues: compare with the clamped true Hessian.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(Hfd);
    const Eigen::Matrix4d Hp =
        es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
    EXPECT_NEAR((H - Hp).norm(), 0, 1e-4 * std::max(1.0, Hp.norm())) << "F=\n" << F;
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(H).eigenvalues().minCoeff(), -1e-9);
  }
}

/// 5x5 vertex grid (unit rest squares); the interior 3x3 free and displaced, the ring pinned.
LocalProblem grid_problem(double jitter, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  LocalProblem p;
  std::vector<int> idx(25);
  std::vector<Vec2> rest(25);
  int nfree = 0;
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) rest[static_cast<size_t>(j * 5 + i)] = Vec2(i, j);
  for (int pass = 0; pass < 2; ++pass)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) {
        const bool interior = i > 0 && i < 4 && j > 0 && j < 4;
        if (interior != (pass == 0)) continue;
        idx[static_cast<size_t>(j * 5 + i)] = static_cast<int>(p.x.size());
        p.x.push_back(Vec2(i, j) + (interior ? Vec2(u(rng), u(rng)) : Vec2::Zero()));
        nfree += interior;
      }
  p.num_free = nfree;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      const int a = j * 5 + i, b = a + 1, c = a + 6, d = a + 5;
      for (const auto& t : {std::array<int, 3>{a, b, c}, std::array<int, 3>{a, c, d}}) {
        p.tri.push_back({idx[static_cast<size_t>(t[0])], idx[static_cast<size_t>(t[1])], idx[static_cast<size_t>(t[2])]});
        Mat2 Dm;
        Dm.col(0) = rest[static_cast<size_t>(t[1])] - rest[static_cast<size_t>(t[0])];
        Dm.col(1) = rest[static_cast<size_t>(t[2])] - rest[static_cast<size_t>(t[0])];
        p.rest_inv.push_back(Dm.inverse());
        p.weight.push_back(0.5);
      }
    }
  return p;
}

TEST(OptCutsSolver, NewtonReturnsToTheRestShape) {
  LocalProblem p = grid_problem(0.3, 1);
  ASSERT_EQ(count_inverted(p), 0);
  const double e0 = sd_total(p);
  SdNewtonSettings s;
  s.iterations = 30;
  const SolveResult r = SdNewtonSolver(s).solve(p);
  ASSERT_TRUE(r.ok);
  EXPECT_LT(sd_total(p), e0);
  EXPECT_NEAR(r.energy, 4.0, 1e-8);  // symmetric Dirichlet of an isometry
  EXPECT_EQ(count_inverted(p), 0);
}

TEST(OptCutsSolver, NewtonUntanglesThenNeverFlips) {
  LocalProblem p = grid_problem(0.9, 5);
  const int inv = count_inverted(p);
  const SolveResult r = SdNewtonSolver().solve(p);
  if (inv > 0) SUCCEED() << inv << " inverted at start";
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(count_inverted(p), 0);
  EXPECT_LT(r.energy, 4.01);
}

// ---- the stage

TEST(OptCuts, FragmentedGridMergesIntoOneChart) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(8, 6, 1024, "unused.png"));
  ASSERT_EQ(run.ctx.atlas.num_charts, 96);
  run.merge("mergers.optcuts");
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  EXPECT_EQ(run.report["charts_out"], 1);
  EXPECT_EQ(run.report["merges_accepted"], 95);
  EXPECT_LT(run.report["distortion_arap"].get<double>(), 1e-10);
  test::expect_valid_atlas(run);
  // Texel density kept: the merged chart's UV area equals the input's.
  double a_in = 0, a_out = 0;
  for (size_t f = 0; f < run.mesh.faces.size(); ++f) {
    a_out += std::abs(atlas_face_area(run.ctx.atlas, static_cast<int>(f)));
    a_in += std::abs(atlas_face_area(run.charts.atlas, static_cast<int>(f)));
  }
  EXPECT_NEAR(a_out, a_in, 1e-6 * a_in);
}

TEST(OptCuts, NeverMergesAcrossRegions) {
  std::vector<int> region;
  TexturedMesh m = test::folded_grid(8, 4, region);
  test::Run run(std::move(m), region);
  run.merge("mergers.optcuts");
  const Atlas& at = run.ctx.atlas;
  std::vector<std::set<int>> regions_of(static_cast<size_t>(at.num_charts));
  for (size_t f = 0; f < run.mesh.faces.size(); ++f)
    regions_of[static_cast<size_t>(at.face_chart[f])].insert(run.ctx.regions.face_region[f]);
  for (const auto& s : regions_of) EXPECT_EQ(s.size(), 1u);
  EXPECT_EQ(at.num_charts, 2);  // each flat half becomes one chart
  test::expect_valid_atlas(run);
}

TEST(OptCuts, OneRegionMergesTheFoldedGridToo) {
  // Without regions (the M-method's behaviour) the fold is just another seam.
  std::vector<int> region;
  TexturedMesh m = test::folded_grid(8, 4, region);
  test::Run run(std::move(m));
  run.merge("mergers.optcuts");
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  test::expect_valid_atlas(run);
}

/// fragmented_grid_mesh(8, 4) left flat, region 0 for faces with x < 4, region 1 for the others: two
/// regions on one plane, so every merge is free of distortion and only the regions separate them.
TexturedMesh flat_two_region_grid(std::vector<int>& region) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(8, 4, 1024, "unused.png");
  region.assign(m.faces.size(), 0);
  for (size_t f = 0; f < m.faces.size(); ++f) {
    double cx = 0;
    for (int k = 0; k < 3; ++k) cx += m.corner_position(f, k).x() / 3;
    region[f] = cx < 4 ? 0 : 1;
  }
  return m;
}

TEST(OptCuts, FlatGridTwoRegionsStaysTwoChartsWithoutSecondPass) {
  std::vector<int> region;
  TexturedMesh m = flat_two_region_grid(region);
  test::Run run(std::move(m), region);
  run.merge("mergers.optcuts");
  EXPECT_EQ(run.ctx.atlas.num_charts, 2);
  EXPECT_EQ(run.report["charts_after_first_pass"], 2);
  EXPECT_EQ(run.report["merges_accepted_second_pass"], 0);
  test::expect_valid_atlas(run);
}

TEST(OptCuts, SecondPassMergesAcrossRegions) {
  for (const char* order : {"mmethod", "planarity"}) {
    SCOPED_TRACE(order);
    std::vector<int> region;
    TexturedMesh m = flat_two_region_grid(region);
    test::Run run(std::move(m), region);
    run.merge("mergers.optcuts", {{"second_pass", "across_regions"}, {"second_pass_priority", order}});
    // First pass: one chart per region; second pass: the two halves meet along the flat seam.
    EXPECT_EQ(run.report["charts_after_first_pass"], 2);
    EXPECT_EQ(run.report["merges_accepted_second_pass"], 1);
    EXPECT_EQ(run.ctx.atlas.num_charts, 1);
    EXPECT_EQ(run.report["merges_accepted"], 63);  // 64 input charts
    EXPECT_LT(run.report["distortion_arap"].get<double>(), 1e-10);
    test::expect_valid_atlas(run);
  }
}

TEST(OptCuts, SecondPassKeepsTheGlobalBound) {
  // A distorted grid in two regions: the second pass merges across them only within the budget.
  for (double bound : {1e-9, 0.025}) {
    std::vector<int> region;
    TexturedMesh m = test::distorted_fragmented_grid(8, 4, 0.05);
    region.assign(m.faces.size(), 0);
    for (size_t f = 0; f < m.faces.size(); ++f) region[f] = m.corner_position(f, 0).x() < 4 ? 0 : 1;
    test::Run run(std::move(m), region);
    run.merge("mergers.optcuts", {{"second_pass", "across_regions"}, {"global_bound", bound}});
    EXPECT_LE(run.report["distortion_arap"].get<double>(), bound + 1e-12);
    if (bound < 1e-6) {
      EXPECT_EQ(run.report["merges_accepted"], 0);
    }
    test::expect_valid_atlas(run);
  }
}

TEST(OptCuts, ForcedRejectionRollsBackExactly) {
  test::Run run(test::distorted_fragmented_grid(6, 4, 0.1));
  const Atlas before = run.ctx.atlas;
  run.merge("mergers.optcuts", {{"global_bound", 1e-9}});
  const Atlas& after = run.ctx.atlas;
  EXPECT_EQ(run.report["merges_accepted"], 0);
  EXPECT_GT(run.report["rejected"]["global_distortion"].get<int>() + run.report["rejected"].value("local_distortion", 0),
            0);
  EXPECT_EQ(after.num_charts, before.num_charts);
  EXPECT_EQ(after.face_chart, before.face_chart);
  EXPECT_EQ(after.face_wedge, before.face_wedge);
  EXPECT_EQ(after.wedge_vertex, before.wedge_vertex);
  ASSERT_EQ(after.wedge_uv.size(), before.wedge_uv.size());
  for (size_t w = 0; w < after.wedge_uv.size(); ++w) EXPECT_EQ(after.wedge_uv[w], before.wedge_uv[w]) << w;
}

TEST(OptCuts, DistortedInputStaysWithinTheBound) {
  test::Run run(test::distorted_fragmented_grid(10, 8, 0.1));
  run.merge("mergers.optcuts", {{"global_bound", 0.01}});
  const double d = run.report["distortion_arap"].get<double>();
  EXPECT_LE(d, 0.01);
  EXPECT_GT(d, 0.0);
  EXPECT_LT(run.ctx.atlas.num_charts, 160 / 2);
  EXPECT_NEAR(atlas_distortion(run.mesh, run.ctx.atlas).arap, d, 1e-12);
  test::expect_valid_atlas(run);
}

/// fragmented_grid_mesh(4, 2) with its last three quarters of faces moved to a second page twice as
/// large (2048 x 2048) whose UVs are halved: the same texel triangles, on another page.
TexturedMesh two_page_grid() {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(4, 2, 1024, "unused.png");
  Page p = m.pages[0];
  p.width = 2048;
  p.height = 2048;
  p.image_path = "unused2.png";
  m.pages.push_back(p);
  for (size_t f = m.faces.size() / 4; f < m.faces.size(); ++f) {
    m.faces[f].page = 1;
    for (int k = 0; k < 3; ++k) m.texcoords[static_cast<size_t>(m.faces[f].vt[static_cast<size_t>(k)])] *= 0.5;
  }
  return m;
}

TEST(OptCuts, ChartsOnDifferentPagesMergeWhenCrossPage) {
  test::Run run(two_page_grid());
  ASSERT_EQ(run.ctx.atlas.num_charts, 16);
  run.merge("mergers.optcuts");
  const Atlas& at = run.ctx.atlas;
  EXPECT_EQ(at.num_charts, 1);
  // Same texel triangles on both pages: the merged chart is an isometry of every input triangle.
  EXPECT_LT(run.report["distortion_arap"].get<double>(), 1e-10);
  EXPECT_LT(atlas_distortion(run.mesh, at).arap, 1e-10);
  // The chart's page is the page of its larger part (page 1: three quarters of the faces).
  ASSERT_EQ(at.chart_page.size(), 1u);
  EXPECT_EQ(at.chart_page[0], 1);
  // Each face keeps its input texel area: fixture cells are 1024 / 4 texels (16 triangles, 4 columns),
  // each triangle a right triangle with legs 0.8 cell.
  const double cell = 1024.0 / 4.0 * 0.8;
  for (size_t f = 0; f < run.mesh.faces.size(); ++f)
    EXPECT_NEAR(std::abs(atlas_face_area(at, static_cast<int>(f))), 0.5 * cell * cell, 1e-6) << f;
  test::expect_valid_atlas(run);
}

TEST(OptCuts, ChartsOnDifferentPagesNeverMergeWithoutCrossPage) {
  test::Run run(two_page_grid());
  run.merge("mergers.optcuts", {{"cross_page", false}});
  EXPECT_EQ(run.ctx.atlas.num_charts, 2);
  for (size_t f = 0; f < run.mesh.faces.size(); ++f)
    EXPECT_EQ(run.ctx.atlas.chart_page[static_cast<size_t>(run.ctx.atlas.face_chart[f])], run.mesh.faces[f].page);
}

TEST(OptCuts, OptionsAreDeclared) {
  Registry& r = Registry::instance();
  r.load_plugins();
  const StageInfo* info = r.find("mergers.optcuts");
  ASSERT_NE(info, nullptr);
  std::set<std::string> keys;
  for (const OptionSpec& o : info->options) keys.insert(o.key);
  for (const char* k : {"priority", "alpha", "global_bound", "local_bound", "max_merges", "max_attempts",
                        "max_free_vertices", "cross_page", "second_pass", "second_pass_priority",
                        "second_pass_local_bound", "newton_iterations", "newton_tolerance"})
    EXPECT_TRUE(keys.count(k)) << k;
  EXPECT_THROW(default_options(*info, {{"global_bound", -1}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"priority", "fastest"}}), std::invalid_argument);
  EXPECT_THROW(default_options(*info, {{"second_pass", "everywhere"}}), std::invalid_argument);
}

}  // namespace
}  // namespace texdefrag::merge
