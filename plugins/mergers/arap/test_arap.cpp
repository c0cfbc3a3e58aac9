// mergers.arap (the M-method's optimiser), created by name, on hand-built meshes.
#include "test_support.h"

#include <gtest/gtest.h>

#include <set>

namespace texdefrag::merge {
namespace {

TEST(Arap, FragmentedGridMergesIntoOneChart) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(8, 6, 1024, "unused.png"));
  run.merge("mergers.arap");
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  EXPECT_LT(run.report["distortion_out"].get<double>(), 1e-10);
  test::expect_valid_atlas(run);
}

TEST(Arap, MMethodPriorityMergesTheGridToo) {
  test::Run run(texdefrag::testing::fragmented_grid_mesh(8, 6, 1024, "unused.png"));
  run.merge("mergers.arap", {{"priority", "mmethod"}});
  EXPECT_EQ(run.ctx.atlas.num_charts, 1);
  test::expect_valid_atlas(run);
}

TEST(Arap, NeverMergesAcrossRegions) {
  std::vector<int> region;
  TexturedMesh m = test::folded_grid(6, 4, region);
  test::Run run(std::move(m), region);
  run.merge("mergers.arap", {{"priority", "mmethod"}});
  std::vector<std::set<int>> regions_of(static_cast<size_t>(run.ctx.atlas.num_charts));
  for (size_t f = 0; f < run.mesh.faces.size(); ++f)
    regions_of[static_cast<size_t>(run.ctx.atlas.face_chart[f])].insert(run.ctx.regions.face_region[f]);
  for (const auto& s : regions_of) EXPECT_EQ(s.size(), 1u);
  // note: the M-method refuses seams under 0.2 of both charts' borders, so two blobs grown in the
  // same half may stay apart; what matters here is that no chart spans both halves.
  EXPECT_GE(run.ctx.atlas.num_charts, 2);
  EXPECT_LE(run.ctx.atlas.num_charts, 4) << run.report.dump();
}

TEST(Arap, LocalBoundRejectsAndRollsBack) {
  test::Run run(test::distorted_fragmented_grid(5, 4, 0.1));
  const Atlas before = run.ctx.atlas;
  run.merge("mergers.arap", {{"local_bound", 0.0}});
  EXPECT_EQ(run.report["merges_accepted"], 0);
  EXPECT_GT(run.report["rejected"].value("local_distortion", 0), 0);
  EXPECT_EQ(run.ctx.atlas.face_wedge, before.face_wedge);
  EXPECT_EQ(run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(run.ctx.atlas.face_chart, before.face_chart);
}

TEST(Arap, DistortedInputStaysWithinTheBound) {
  test::Run run(test::distorted_fragmented_grid(10, 8, 0.05));
  run.merge("mergers.arap", {{"priority", "mmethod"}});
  EXPECT_LE(run.report["distortion_out"].get<double>(), 0.025);
  EXPECT_LT(run.ctx.atlas.num_charts, 160);
  test::expect_valid_atlas(run);
}

}  // namespace
}  // namespace texdefrag::merge
