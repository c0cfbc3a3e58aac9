// mergers.optcuts and mergers.arap on the real tiles under ../shared/data (skipped when absent),
// with one region for all faces (the M-method's behaviour): invariants, and the numbers printed.
#include "test_overlaps.h"
#include "test_support.h"

#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>

namespace texdefrag::merge {
namespace {

void run_real(const std::string& stage, const json& options, double max_fraction_left,
              const std::string& detector = "") {
  const auto models = texdefrag::testing::real_models(25000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  for (const std::string& path : models) {
    SCOPED_TRACE(path);
    test::Run run(read_obj(path));
    if (!detector.empty() && !run.detect(detector)) GTEST_SKIP() << detector << " is not built";
    const auto t0 = std::chrono::steady_clock::now();
    run.merge(stage, options);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const json& r = run.report;
    const size_t in = r["charts_in"], out = r["charts_out"];
    std::printf("%s %s: %zu faces, %zu charts => %zu charts (-%.1f%%), E=%.5f, flips=%zu, %zu/%zu merges, "
                "optimisation %.2f s, total %.2f s, rejected %s\n",
                stage.c_str(), std::filesystem::path(path).filename().c_str(), run.mesh.faces.size(), in, out,
                100.0 * static_cast<double>(in - out) / static_cast<double>(in), r["distortion_arap"].get<double>(),
                r["flipped_faces"].get<size_t>(), r["merges_accepted"].get<size_t>(), r["merges_attempted"].get<size_t>(),
                r["optimisation_seconds"].get<double>(), secs, r["rejected"].dump().c_str());
    test::expect_valid_atlas(run);
    EXPECT_LE(r["distortion_arap"].get<double>(), options.value("global_bound", 0.025) + 1e-12);
    EXPECT_EQ(r["flipped_faces"], 0);
    // Chart count drops a lot on photogrammetry tiles (thousands of tiny charts).
    EXPECT_LT(static_cast<double>(out), max_fraction_left * static_cast<double>(in));
    // Merging never creates UV overlaps: per output chart, overlapping triangle pairs in the atlas are
    // at most those its faces already had in the input (per input page; eval's exact test).
    const auto [ov_in, ov_out] = test::overlaps_in_out(run);
    std::printf("  overlapping pairs within output charts: input %zu, output %zu\n", ov_in, ov_out);
    EXPECT_LE(ov_out, ov_in);
    // Each chart's page is one of its faces' input pages.
    std::vector<std::set<int>> pages(static_cast<size_t>(run.ctx.atlas.num_charts));
    for (size_t f = 0; f < run.mesh.faces.size(); ++f)
      if (run.mesh.faces[f].page != kNoPage)
        pages[static_cast<size_t>(run.ctx.atlas.face_chart[f])].insert(run.mesh.faces[f].page);
    for (size_t c = 0; c < pages.size(); ++c) EXPECT_TRUE(pages[c].count(run.ctx.atlas.chart_page[c])) << c;
  }
}

// note: the M-method's order (best-aligned seams first) is the right one without regions; with the
// planarity order and no detector the largest chart absorbs its neighbours across building edges
// until the distortion budget is spent (about half the charts go; measured numbers in docs/mergers.md).
TEST(OptCutsReal, MMethodOrderOnRealTiles) { run_real("mergers.optcuts", {{"priority", "mmethod"}}, 0.25); }
TEST(OptCutsReal, PlanarityOrderWithoutRegions) { run_real("mergers.optcuts", json::object(), 0.6); }
// The paper's configuration: region_growing regions, planarity order.
TEST(OptCutsReal, PlanarityOrderWithRegionGrowing) {
  run_real("mergers.optcuts", json::object(), 0.5, "detectors.region_growing");
}
// configs/best.json's merger: the paper's configuration, then a second pass across regions.
TEST(OptCutsReal, SecondPassAcrossRegions) {
  run_real("mergers.optcuts",
           {{"second_pass", "across_regions"}, {"second_pass_local_bound", 0.1}, {"second_pass_seam_refusal", false}},
           0.25, "detectors.region_growing");
}
TEST(ArapReal, MMethodOnRealTiles) { run_real("mergers.arap", {{"priority", "mmethod"}}, 0.25); }

}  // namespace
}  // namespace texdefrag::merge
