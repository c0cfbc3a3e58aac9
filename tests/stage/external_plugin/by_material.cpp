// mergers.by_material: an out-of-tree merger that adds a constraint to the exported merge engine
// (texdefrag::merge_engine): two charts may merge only when they are in the same detector region
// AND their faces use the same OBJ material. The engine does the rest (seam candidates, local
// ARAP, the distortion, flip and overlap checks, rollback).
#include <arap_solver.h>
#include <merge_engine.h>
#include <texdefrag/stage/registry.h>

#include <map>
#include <utility>

namespace {

using namespace texdefrag;

class ByMaterialMerger final : public Merger {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "mergers.by_material";
    i.kind = StageKind::Merger;
    i.description = "Seam merging (ARAP) restricted to charts of one region and one material (out-of-tree example)";
    i.doc = "docs/writing-a-stage.md";
    i.options = merge::merge_option_specs();
    i.create = [] { return std::make_unique<ByMaterialMerger>(); };
    return i;
  }
  void merge(StageContext& ctx) override {
    // The constraint: a region per (detector region, material) pair.
    const auto& faces = ctx.mesh->faces;
    std::map<std::pair<int, int>, int> id;
    std::vector<int> face_region(faces.size(), -1);
    for (size_t f = 0; f < faces.size(); ++f) {
      if (faces[f].page == kNoPage) continue;
      const int region = ctx.regions.face_region.empty() ? 0 : ctx.regions.face_region[f];
      face_region[f] = id.emplace(std::make_pair(region, faces[f].material), static_cast<int>(id.size())).first->second;
    }
    merge::ArapSolver solver(merge::ArapSettings{});
    const merge::MergeReport r =
        merge::run_merges(*ctx.mesh, *ctx.topology, ctx.atlas, face_region, merge::merge_options_from(options()), solver,
                          [&](double f) { ctx.step(info().name, f); });
    *ctx.report = r.to_json();
    (*ctx.report)["constraint_regions"] = id.size();
  }
};

}  // namespace

TEXDEFRAG_PLUGIN(ByMaterialMerger)
