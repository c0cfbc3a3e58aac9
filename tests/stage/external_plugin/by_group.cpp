// detectors.by_group: an out-of-tree detector whose regions are the OBJ's `g`/`o` groups, so
// charts of different objects never merge. Built outside the texdefrag tree, loaded through
// TEXDEFRAG_PLUGIN_PATH.
#include <texdefrag/stage/registry.h>

#include <map>

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
    i.create = [] { return std::make_unique<ByGroup>(); };
    return i;
  }
  void detect(texdefrag::StageContext& ctx) override {
    const auto& faces = ctx.mesh->faces;
    std::map<int, int> region_of_group;
    ctx.regions.face_region.assign(faces.size(), -1);
    for (size_t f = 0; f < faces.size(); ++f) {
      if (faces[f].page == texdefrag::kNoPage) continue;
      int g = faces[f].group;
      if (g < 0 && !options().get_bool("ungrouped_region"))
        throw texdefrag::StageError("detectors.by_group: face " + std::to_string(f) + " (line " +
                                    std::to_string(faces[f].source_line) + ") belongs to no group");
      auto it = region_of_group.emplace(g, static_cast<int>(region_of_group.size())).first;
      ctx.regions.face_region[f] = it->second;
    }
    ctx.regions.num_regions = static_cast<int>(region_of_group.size());
    (*ctx.report)["groups"] = region_of_group.size();
  }
};

}  // namespace

TEXDEFRAG_PLUGIN(ByGroup)
