// mergers.arap: seam merging with the M-method's local/global ARAP optimiser (Maggiordomo et al.
// 2021) on the shared merge engine; with priority = "mmethod" it is our M-method baseline.
#include "arap_solver.h"
#include "merge_engine.h"

#include "texdefrag/stage/registry.h"

namespace texdefrag {
namespace {

class ArapMerger final : public Merger {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "mergers.arap";
    i.kind = StageKind::Merger;
    i.description =
        "Merges charts seam by seam; local/global ARAP of the seam's neighbourhood against the input UV "
        "triangles (Maggiordomo et al. 2021), rollback on distortion, flips or overlaps";
    i.doc = "docs/mergers.md";
    i.options = merge::merge_option_specs();
    i.options.push_back(opt_int("arap_iterations", 10, "Local/global ARAP iterations per merge").range(1, 1000));
    i.options.push_back(
        opt_double("arap_tolerance", 1e-6, "Stop when the ARAP energy drops by less than this fraction").range(0, 1));
    i.create = [] { return std::make_unique<ArapMerger>(); };
    return i;
  }
  void merge(StageContext& ctx) override {
    merge::ArapSettings s;
    s.iterations = static_cast<int>(options().get_int("arap_iterations"));
    s.tolerance = options().get_double("arap_tolerance");
    merge::ArapSolver solver(s);
    merge::run_merge_stage(ctx, info().name, merge::merge_options_from(options()), solver);
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::ArapMerger)
