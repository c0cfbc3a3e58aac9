// detectors.semantic: regions from semantic classes (ground, vegetation, building, other) estimated
// from geometry alone (semantic/classify.h), so that merges never join a facade with the street or
// a tree: the semantic merge constraint Liu et al. 2024 name as future work (section 5).
// Regions are the connected same-class pieces (`regions: components`) or the classes themselves
// (`regions: classes`). To combine them with planar regions, write the labels (`write_labels`) and
// run detectors.labels with `intersect_with: detectors.region_growing` (docs/detectors.md).
#include "common/region_output.h"
#include "semantic/classify.h"
#include "texdefrag/stage/registry.h"

namespace texdefrag::detectors {
namespace {

constexpr const char* kName = "detectors.semantic";

semantic::ClassifyOptions classify_options(const Options& o) {
  semantic::ClassifyOptions c;
  const std::string up = o.get_string("up_axis");
  c.up = up == "x" ? Vec3::UnitX() : up == "y" ? Vec3::UnitY() : Vec3::UnitZ();
  c.ground_cell = o.get_double("ground_cell");
  c.ground_window = o.get_double("ground_window");
  c.ground_height = o.get_double("ground_height");
  c.ground_slope_deg = o.get_double("ground_slope_deg");
  c.patch_rings = static_cast<int>(o.get_int("patch_rings"));
  c.vegetation_scatter = o.get_double("vegetation_scatter");
  c.vegetation_coherence = o.get_double("vegetation_coherence");
  c.building_min_height = o.get_double("building_min_height");
  c.building_min_area = o.get_double("building_min_area");
  c.plane_angle_deg = o.get_double("plane_angle_deg");
  c.plane_min_area = o.get_double("plane_min_area");
  c.building_min_planar_fraction = o.get_double("building_min_planar_fraction");
  c.min_component_faces = static_cast<int>(o.get_int("min_component_faces"));
  return c;
}

class SemanticDetector final : public Detector {
 public:
  void set_options(const Options& o) override {
    Stage::set_options(o);
    check_region_output_options(kName, o);
  }
  static StageInfo info() {
    const semantic::ClassifyOptions d;
    StageInfo i;
    i.name = kName;
    i.kind = StageKind::Detector;
    i.description = "Regions from semantic classes (ground, vegetation, building, other) estimated from geometry";
    i.doc = "docs/detectors.md";
    i.options = {
        opt_enum("up_axis", "z", {"z", "y", "x"}, "Vertical axis of the model (ContextCapture OBJ/OSGB: z; glTF: y)"),
        opt_enum("regions", "components", {"components", "classes"},
                 "Regions are the connected same-class pieces, or one region per class"),
        opt_double("ground_cell", d.ground_cell, "Side of the ground grid's cells").range(0.05, 1000).unit("m"),
        opt_double("ground_window", d.ground_window, "Opening window of the ground filter: wider than the widest building")
            .range(0.1, 10000).unit("m"),
        opt_double("ground_height", d.ground_height, "Faces lower than this above the ground may be ground").range(0, 100).unit("m"),
        opt_double("ground_slope_deg", d.ground_slope_deg, "Ground faces are within this angle of horizontal").range(0, 90).unit("deg"),
        opt_int("patch_rings", d.patch_rings, "Face rings of the patch over which scatter and coherence are measured").range(1, 10),
        opt_double("vegetation_scatter", d.vegetation_scatter,
                   "A rough patch has a normal scatter (1 - |area-weighted mean unit normal|) above this").range(0, 1),
        opt_double("vegetation_coherence", d.vegetation_coherence,
                   "A rough patch has less than this area fraction within 20 deg of the face's normal").range(0, 1),
        opt_double("building_min_height", d.building_min_height, "A building reaches at least this height above ground")
            .range(0, 1000).unit("m"),
        opt_double("building_min_area", d.building_min_area, "A building's connected smooth surface covers at least this area")
            .range(0, 1e7).unit("m^2"),
        opt_double("plane_angle_deg", d.plane_angle_deg, "A planar patch holds faces within this angle of its seed face's normal")
            .range(0.1, 90).unit("deg"),
        opt_double("plane_min_area", d.plane_min_area, "Planar patches at least this large count as planes").range(0, 1e7).unit("m^2"),
        opt_double("building_min_planar_fraction", d.building_min_planar_fraction,
                   "A building has at least this area fraction in such planes; tall, large and less planar is vegetation")
            .range(0, 1),
        opt_int("min_component_faces", d.min_component_faces, "Same-class islands with fewer faces take their neighbours' class")
            .range(1, 100000),
    };
    for (OptionSpec& o : output_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<SemanticDetector>(); };
    return i;
  }

  void detect(StageContext& ctx) override {
    if (!ctx.mesh || !ctx.topology || !ctx.report) throw StageError(std::string(kName) + ": needs the mesh, topology and a report node");
    const TexturedMesh& mesh = *ctx.mesh;
    ctx.step(kName, 0.0);
    const semantic::Classification c = semantic::classify_faces(mesh, *ctx.topology, classify_options(options()));
    ctx.step(kName, 0.8);
    std::vector<int> label(mesh.faces.size(), -1);
    for (size_t f = 0; f < label.size(); ++f)
      if (mesh.faces[f].page != kNoPage) label[f] = static_cast<int>(c.face_class[f]);
    if (options().get_string("regions") == "components") {
      int n = 0;
      label = semantic::label_components(*ctx.topology, label, n);
    }
    ctx.regions = regions_from_labels(label);
    json& rep = *ctx.report;
    report_classes(c, label, rep);
    report_region_stats(ctx.regions, rep);
    write_region_outputs(kName, options(), ctx);
    ctx.step(kName, 1.0);
  }

 private:
  /// Class figures and the class of every region (region ids as numbered by regions_from_labels).
  void report_classes(const semantic::Classification& c, const std::vector<int>& label, json& rep) const {
    json faces = json::object(), area = json::object();
    for (int k = 0; k < semantic::kNumClasses; ++k) {
      const char* name = semantic::class_name(static_cast<semantic::FaceClass>(k));
      faces[name] = c.faces_per_class[static_cast<size_t>(k)];
      area[name] = c.area_per_class[static_cast<size_t>(k)];
    }
    rep["class_faces"] = faces;
    rep["class_area"] = area;
    rep["building_components"] = c.building_components;
    rep["relabelled_islands"] = c.relabelled_islands;
    rep["nonplanar_components"] = c.nonplanar_components;
    const Regions r = regions_from_labels(label);
    json region_class = json::array();
    std::vector<std::string> names(static_cast<size_t>(r.num_regions));
    for (size_t f = 0; f < label.size(); ++f)
      if (r.face_region[f] >= 0) names[static_cast<size_t>(r.face_region[f])] = semantic::class_name(c.face_class[f]);
    for (const auto& n : names) region_class.push_back(n);
    rep["region_class"] = region_class;
  }
};

}  // namespace
}  // namespace texdefrag::detectors

TEXDEFRAG_PLUGIN(texdefrag::detectors::SemanticDetector)
