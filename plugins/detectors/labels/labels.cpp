// detectors.labels: regions from per-face labels in a file (e.g. semantic classes from a
// segmentation network, or a detection saved with `write_labels` and edited), optionally
// intersected with another detector's regions. Shows how a new merge constraint plugs in: mergers
// only join charts within one region (Liu et al. 2024, section 2.2.1: planar regions as merge
// constraints; here the constraint comes from outside).
#include "common/label_io.h"
#include "common/region_output.h"
#include "texdefrag/stage/registry.h"

#include <map>

namespace texdefrag::detectors {
namespace {

constexpr const char* kName = "detectors.labels";

class LabelsDetector final : public Detector {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = kName;
    i.kind = StageKind::Detector;
    i.description = "Regions from per-face labels in a file, optionally intersected with another detector's regions";
    i.doc = "docs/detectors.md";
    i.options = {
        opt_input_path("path", "Label file: one integer per line in input face order, or .json {\"face_labels\": [...]}")
            .required(),
        opt_stage("intersect_with", "detectors",
                   "Another detector (e.g. detectors.region_growing, run with its defaults); regions are then "
                   "the faces sharing both a label and that detector's region. Empty = no intersection"),
    };
    for (OptionSpec& o : output_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<LabelsDetector>(); };
    return i;
  }

  void set_options(const Options& o) override {
    Stage::set_options(o);
    const std::string other = o.get_string("intersect_with");
    if (other == kName) throw StageError(std::string(kName) + ": 'intersect_with' cannot be detectors.labels itself");
    check_region_output_options(kName, o);
  }

  void detect(StageContext& ctx) override {
    if (!ctx.mesh || !ctx.report) throw StageError(std::string(kName) + ": needs the mesh and a report node");
    const std::string path = options().get_string("path");
    if (path.empty()) throw StageError(std::string(kName) + ": option 'path' (the label file) is required");
    const TexturedMesh& mesh = *ctx.mesh;
    std::vector<size_t> lines;
    std::vector<int> labels = read_face_labels(kName, path, mesh.faces.size(), &lines);
    size_t ignored = 0;
    for (size_t f = 0; f < labels.size(); ++f) {
      if (mesh.faces[f].page == kNoPage) {
        ignored += labels[f] >= 0;
        labels[f] = -1;
      } else if (labels[f] < 0) {
        throw StageError(std::string(kName) + ": " + path + (lines[f] ? ":" + std::to_string(lines[f]) : "") +
                         ": face " + std::to_string(f) + " (OBJ line " + std::to_string(mesh.faces[f].source_line) +
                         ") is textured but has label " + std::to_string(labels[f]) + " (no region)");
      }
    }
    json& rep = *ctx.report;
    rep["labels_on_untextured_faces_ignored"] = ignored;
    const std::string other = options().get_string("intersect_with");
    if (!other.empty()) {
      Registry& reg = Registry::instance();
      const StageInfo* info = reg.find(other);
      std::unique_ptr<Stage> stage;
      try {
        stage = reg.create(other);
      } catch (const std::exception& e) {
        throw StageError(std::string(kName) + ": intersect_with: " + e.what());
      }
      auto* det = dynamic_cast<Detector*>(stage.get());
      if (!det || !info) throw StageError(std::string(kName) + ": intersect_with: '" + other + "' is not a detector");
      det->set_options(default_options(*info));
      StageContext sub;
      sub.mesh = ctx.mesh;
      sub.topology = ctx.topology;
      sub.input_charts = ctx.input_charts;
      sub.atlas = ctx.atlas;
      json sub_report = json::object();
      sub.report = &sub_report;
      sub.progress = ctx.progress;
      sub.input_path = ctx.input_path;
      sub.outputs = ctx.outputs;
      det->detect(sub);
      if (sub.regions.face_region.size() != labels.size())
        throw StageError(std::string(kName) + ": intersect_with: " + other + " returned regions for " +
                         std::to_string(sub.regions.face_region.size()) + " faces");
      std::map<std::pair<int, int>, int> combined;
      for (size_t f = 0; f < labels.size(); ++f) {
        if (labels[f] < 0) continue;
        const int r = sub.regions.face_region[f];
        labels[f] = combined.emplace(std::make_pair(labels[f], r), static_cast<int>(combined.size())).first->second;
      }
      rep["intersect_with"] = other;
      rep["intersect_regions"] = sub.regions.num_regions;
      rep["intersect_report"] = sub_report;
    }
    ctx.regions = regions_from_labels(labels);
    report_region_stats(ctx.regions, rep);
    write_region_outputs(kName, options(), ctx);
  }
};

}  // namespace
}  // namespace texdefrag::detectors

TEXDEFRAG_PLUGIN(texdefrag::detectors::LabelsDetector)
