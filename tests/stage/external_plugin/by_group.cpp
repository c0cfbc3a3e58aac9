// detectors.by_group: an out-of-tree detector whose regions are the OBJ's `g`/`o` groups, so
// charts of different objects never merge. Built outside the texdefrag tree, loaded through
// TEXDEFRAG_PLUGIN_PATH.
// Uses the exported detector helpers (texdefrag::detectors_common): region numbering, region
// statistics and the write_labels / write_colored outputs every detector offers.
#include <common/region_output.h>
#include <texdefrag/stage/registry.h>

#include <vector>

namespace {

class ByGroup final : public texdefrag::Detector {
 public:
  static texdefrag::StageInfo info() {
    texdefrag::StageInfo i;
    i.name = "detectors.by_group";
    i.kind = texdefrag::StageKind::Detector;
    i.description = "One region per OBJ group (g/o statement)";
    i.doc = "tests/stage/external_plugin/by_group.cpp";
    i.options = {texdefrag::opt_bool("ungrouped_region", true,
                                     "Faces before any g/o statement form one region of their own")};
    for (texdefrag::OptionSpec& o : texdefrag::detectors::output_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<ByGroup>(); };
    return i;
  }
  void detect(texdefrag::StageContext& ctx) override {
    const auto& faces = ctx.mesh->faces;
    std::vector<int> label(faces.size(), -1);  // -1: untextured, in no region
    for (size_t f = 0; f < faces.size(); ++f) {
      if (faces[f].page == texdefrag::kNoPage) continue;
      if (faces[f].group < 0 && !options().get_bool("ungrouped_region"))
        throw texdefrag::StageError("detectors.by_group: face " + std::to_string(f) + " (line " +
                                    std::to_string(faces[f].source_line) + ") belongs to no group");
      label[f] = faces[f].group + 1;  // faces before any g/o statement: label 0
    }
    ctx.regions = texdefrag::detectors::regions_from_labels(label);  // numbered by size, largest first
    texdefrag::detectors::report_region_stats(ctx.regions, *ctx.report);
    (*ctx.report)["groups"] = ctx.regions.num_regions;
    texdefrag::detectors::write_region_outputs("detectors.by_group", options(), ctx);
  }
};

}  // namespace

TEXDEFRAG_PLUGIN(ByGroup)
