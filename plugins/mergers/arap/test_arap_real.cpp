// mergers.arap with each ARAP solver on the real tiles under ../shared/data up to 10k faces (the
// rural ContextCapture tiles; skipped when absent), M-method order, one region: invariants of each
// result, and the two solvers' outcomes side by side (they minimise the same energy).
#include "test_overlaps.h"
#include "test_support.h"

#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

namespace texdefrag::merge {
namespace {

TEST(ArapReal, EigenAndCeresSolversOnRuralTiles) {
  const auto models = texdefrag::testing::real_models(10000);
  if (models.empty()) GTEST_SKIP() << "no real models up to 10k faces under ../shared/data";
  for (const std::string& path : models) {
    SCOPED_TRACE(path);
    std::map<std::string, size_t> charts_out;
    for (const char* solver : {"eigen", "ceres"}) {
      test::Run run(read_obj(path));
      const auto t0 = std::chrono::steady_clock::now();
      run.merge("mergers.arap", {{"priority", "mmethod"}, {"solver", solver}});
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const json& r = run.report;
      const size_t in = r["charts_in"], out = r["charts_out"];
      const auto [ov_in, ov_out] = test::overlaps_in_out(run);
      std::printf("%s %s: %zu charts => %zu, E=%.5f, %zu/%zu merges, optimisation %.2f s, total %.2f s, "
                  "overlapping pairs %zu (input %zu)\n",
                  std::filesystem::path(path).filename().c_str(), solver, in, out, r["distortion_arap"].get<double>(),
                  r["merges_accepted"].get<size_t>(), r["merges_attempted"].get<size_t>(),
                  r["optimisation_seconds"].get<double>(), secs, ov_out, ov_in);
      test::expect_valid_atlas(run);
      EXPECT_EQ(r["flipped_faces"], 0);
      EXPECT_LE(r["distortion_arap"].get<double>(), 0.025 + 1e-12);
      EXPECT_LT(static_cast<double>(out), 0.25 * static_cast<double>(in));
      EXPECT_LE(ov_out, ov_in);
      charts_out[solver] = out;
    }
    // Same energy, same acceptance tests: the outcomes differ only through the solvers' different
    // stopping points (measured, eigen vs ceres: t078_L15 197 vs 199 and t078_L17 131 vs 132 charts;
    // 190 vs 192 and 127 vs 128 after the engine's island lookahead, commit 60054ff).
    const double e = static_cast<double>(charts_out["eigen"]), c = static_cast<double>(charts_out["ceres"]);
    EXPECT_LE(std::abs(e - c), 0.05 * e);
  }
}

}  // namespace
}  // namespace texdefrag::merge
