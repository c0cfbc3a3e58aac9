// mergers.arap: seam merging with the M-method's local/global ARAP optimiser (Maggiordomo et al.
// 2021) on the shared merge engine; with priority = "mmethod" it is our M-method baseline. The
// `solver` option picks the minimiser of the same ARAP energy: the prefactored Eigen local/global
// solver (engine/arap_solver.h) or Levenberg-Marquardt on Ceres (ceres_arap_solver.h).
#include "arap_solver.h"
#include "ceres_arap_solver.h"
#include "merge_engine.h"

#include "texdefrag/stage/registry.h"

namespace texdefrag {
namespace {

class ArapMerger final : public Merger {
 public:
  void set_options(const Options& o) override {
    Stage::set_options(o);
    if (o.get_bool("untangle") && o.get_string("solver") == "ceres")
      throw StageError("mergers.arap: untangle = true needs solver = \"eigen\" (the Ceres solver has no injectivity repair)");
  }
  static StageInfo info() {
    StageInfo i;
    i.name = "mergers.arap";
    i.kind = StageKind::Merger;
    i.description =
        "Merges charts seam by seam; ARAP of the seam's neighbourhood against the input UV triangles "
        "(Maggiordomo et al. 2021; local/global on Eigen or Levenberg-Marquardt on Ceres), rollback on "
        "distortion, flips or overlaps";
    i.doc = "docs/mergers.md";
    i.options = merge::merge_option_specs();
    i.options.push_back(opt_enum("solver", "eigen", {"eigen", "ceres"},
                                 "ARAP minimiser: eigen = local/global, matrix factorised once per merge; ceres = "
                                 "Levenberg-Marquardt, sparse normal Cholesky every iteration"));
    i.options.push_back(
        opt_int("arap_iterations", 10, "ARAP iterations per merge (local/global steps, or Ceres LM steps)").range(1, 1000));
    i.options.push_back(
        opt_double("arap_tolerance", 1e-6, "Stop when the ARAP energy drops by less than this fraction").range(0, 1));
    i.options.push_back(opt_bool("untangle", false,
                                 "When the local/global steps end with inverted triangles, untangle the free region "
                                 "(Garanzha et al. 2021) and go on with steps that never turn a triangle over (eigen "
                                 "solver only)"));
    i.create = [] { return std::make_unique<ArapMerger>(); };
    return i;
  }
  /// The engine's global bound (docs/mergers.md step 7), which the pipeline checks after merging.
  std::optional<double> distortion_budget() const override { return options().get_double("global_bound"); }
  void merge(StageContext& ctx) override {
    const int iterations = static_cast<int>(options().get_int("arap_iterations"));
    const double tolerance = options().get_double("arap_tolerance");
    const merge::MergeOptions mo = merge::merge_options_from(options());
    if (options().get_enum<bool>("solver", {{"eigen", false}, {"ceres", true}})) {
      merge::CeresArapSettings s;
      s.iterations = iterations;
      s.tolerance = tolerance;
      merge::CeresArapSolver solver(s);
      merge::run_merge_stage(ctx, info().name, mo, solver);
    } else {
      merge::ArapSettings s;
      s.iterations = iterations;
      s.tolerance = tolerance;
      s.untangle = options().get_bool("untangle");
      s.singular_value_floor = mo.min_singular_value;
      merge::ArapSolver solver(s);
      merge::run_merge_stage(ctx, info().name, mo, solver);
    }
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::ArapMerger)
