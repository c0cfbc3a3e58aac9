// mergers.optcuts: plane-constrained seam merging with an OptCuts-style optimiser (projected Newton
// on the symmetric Dirichlet energy, flip-free line search): Liu et al. 2024, section 2.2.
#include "merge_engine.h"
#include "sd_newton.h"

#include "texdefrag/stage/registry.h"

namespace texdefrag {
namespace {

class OptCutsMerger final : public Merger {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "mergers.optcuts";
    i.kind = StageKind::Merger;
    i.description =
        "Merges charts seam by seam within each region; projected-Newton symmetric Dirichlet optimisation "
        "of the seam's neighbourhood, rollback on distortion, flips or overlaps (Liu et al. 2024)";
    i.doc = "docs/mergers.md";
    // note: local_bound 0.1 (not the M-method's 0.5): with planar regions the chart count is bounded
    // by the regions and by overlaps, not by the distortion budget; refusing the few merges that
    // distort their neighbourhood a lot keeps E far under the global bound for the same count
    // (t015_L18: 0.5 => 1369 charts, E 0.025; 0.1 => about 1300 charts, E about 0.017).
    i.options = merge::merge_option_specs(0.1);
    i.options.push_back(opt_int("newton_iterations", 10, "Projected Newton iterations per merge").range(1, 1000));
    i.options.push_back(
        opt_double("newton_tolerance", 1e-6, "Stop when the Newton decrement is below this fraction of the energy")
            .range(0, 1));
    i.create = [] { return std::make_unique<OptCutsMerger>(); };
    return i;
  }
  /// The engine's global bound (docs/mergers.md step 7), which the pipeline checks after merging.
  std::optional<double> distortion_budget() const override { return options().get_double("global_bound"); }
  void merge(StageContext& ctx) override {
    merge::SdNewtonSettings s;
    s.iterations = static_cast<int>(options().get_int("newton_iterations"));
    s.tolerance = options().get_double("newton_tolerance");
    merge::SdNewtonSolver solver(s);
    merge::run_merge_stage(ctx, info().name, merge::merge_options_from(options()), solver);
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::OptCutsMerger)
