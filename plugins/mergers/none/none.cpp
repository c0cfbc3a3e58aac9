// mergers.none: keeps the input charts and UVs as they are (repacking only).
#include "texdefrag/stage/registry.h"

namespace texdefrag {
namespace {

class NoneMerger final : public Merger {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "mergers.none";
    i.kind = StageKind::Merger;
    i.description = "Keeps the input charts (no merging); with a packer this repacks the atlas";
    i.doc = "plugins/mergers/none/README.md";
    i.create = [] { return std::make_unique<NoneMerger>(); };
    return i;
  }
  void merge(StageContext& ctx) override {
    ctx.atlas.compact();
    (*ctx.report)["merges"] = 0;
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::NoneMerger)
