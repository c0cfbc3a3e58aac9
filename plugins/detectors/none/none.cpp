// detectors.none: one region holding every textured face, so mergers may join any two charts.
// This is the M-method's behaviour (no planar constraint) and the ablation baseline.
#include "texdefrag/stage/registry.h"

namespace texdefrag {
namespace {

class NoneDetector final : public Detector {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "detectors.none";
    i.kind = StageKind::Detector;
    i.description = "One region for all textured faces (no merge constraint; the M-method's behaviour)";
    i.doc = "plugins/detectors/none/README.md";
    i.create = [] { return std::make_unique<NoneDetector>(); };
    return i;
  }
  void detect(StageContext& ctx) override {
    const auto& faces = ctx.mesh->faces;
    ctx.regions.face_region.assign(faces.size(), -1);
    size_t textured = 0;
    for (size_t f = 0; f < faces.size(); ++f)
      if (faces[f].page != kNoPage) {
        ctx.regions.face_region[f] = 0;
        ++textured;
      }
    ctx.regions.num_regions = textured ? 1 : 0;
    (*ctx.report)["textured_faces"] = textured;
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::NoneDetector)
