// detectors.angle_growing: plain normal-angle region growing, the "traditional" method that
//   Liu et al. 2024 (Remote Sensing 16(22):4154, section 2.1.3 and Figure 3) compare against.
// Units are faces (default) or input charts; a neighbour joins when the angle between its normal
// and the normal of the unit it is reached from ("neighbour", smoothness-constrained growing as in
// Rabbani et al. 2006) or the region's area-weighted mean normal ("region") is under the threshold.
// No planarity index, no refinements: this is the baseline for the ablations.
#include "common/planarity.h"
#include "common/region_output.h"
#include "common/units.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <cmath>
#include <deque>

namespace texdefrag::detectors {
namespace {

constexpr const char* kName = "detectors.angle_growing";

class AngleGrowingDetector final : public Detector {
 public:
  void set_options(const Options& o) override {
    Stage::set_options(o);
    check_region_output_options(kName, o);
  }
  static StageInfo info() {
    StageInfo i;
    i.name = kName;
    i.kind = StageKind::Detector;
    i.description = "Plain normal-angle region growing over faces or charts (the baseline the paper compares against)";
    i.doc = "docs/detectors.md";
    i.options = {
        opt_double("angle_threshold_deg", 25, "A unit joins when its normal is within this angle of the reference normal").range(0, 90).unit("deg"),
        opt_enum("unit", "faces", {"faces", "patches"}, "Growing units: single faces, or the input charts (plane-fitted)"),
        opt_enum("reference", "neighbour", {"neighbour", "region"},
                 "Compare with the normal of the unit growth comes from, or with the region's mean normal"),
    };
    for (OptionSpec& o : output_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<AngleGrowingDetector>(); };
    return i;
  }

  void detect(StageContext& ctx) override {
    if (!ctx.mesh || !ctx.topology || !ctx.input_charts || !ctx.report)
      throw StageError(std::string(kName) + ": needs the mesh, its topology, its charts and a report node");
    const double thr = options().get_double("angle_threshold_deg") * M_PI / 180;
    const bool patches = options().get_enum<bool>("unit", {{"faces", false}, {"patches", true}});
    const bool to_region = options().get_enum<bool>("reference", {{"neighbour", false}, {"region", true}});
    json& rep = *ctx.report;
    ctx.step(kName, 0.0);
    std::vector<int> face_unit;
    int nu = 0;
    if (patches) {
      face_unit = ctx.input_charts->atlas.face_chart;
      nu = ctx.input_charts->atlas.num_charts;
    } else {
      nu = faces_as_units(*ctx.mesh, face_unit);
    }
    const UnitGraph g = build_unit_graph(*ctx.mesh, *ctx.topology, std::move(face_unit), nu, reference_point(*ctx.mesh));
    ctx.step(kName, 0.5);
    // Seeds in decreasing area; zero-area units never pass the angle test and stay single.
    std::vector<int> order(static_cast<size_t>(nu));
    for (int u = 0; u < nu; ++u) order[static_cast<size_t>(u)] = u;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return g.moments[static_cast<size_t>(a)].area > g.moments[static_cast<size_t>(b)].area;
    });
    std::vector<int> region(static_cast<size_t>(nu), -1);
    int n = 0;
    std::deque<int> q;
    for (int s0 : order) {
      if (region[static_cast<size_t>(s0)] >= 0) continue;
      const int r = n++;
      region[static_cast<size_t>(s0)] = r;
      Vec3 mean = g.moments[static_cast<size_t>(s0)].area * g.fits[static_cast<size_t>(s0)].normal;
      q.assign(1, s0);
      while (!q.empty()) {
        const int s = q.front();
        q.pop_front();
        const Vec3 ref = to_region ? mean : g.fits[static_cast<size_t>(s)].normal;
        for (int i = g.adj_offset[static_cast<size_t>(s)]; i < g.adj_offset[static_cast<size_t>(s) + 1]; ++i) {
          const int v = g.adj[static_cast<size_t>(i)];
          if (region[static_cast<size_t>(v)] >= 0 || !g.fits[static_cast<size_t>(v)].valid) continue;
          if (normal_angle(g.fits[static_cast<size_t>(v)].normal, ref) >= thr) continue;
          region[static_cast<size_t>(v)] = r;
          mean += g.moments[static_cast<size_t>(v)].area * g.fits[static_cast<size_t>(v)].normal;
          q.push_back(v);
        }
      }
    }
    std::vector<int> face_label(ctx.mesh->faces.size(), -1);
    for (size_t f = 0; f < face_label.size(); ++f)
      if (g.face_unit[f] >= 0) face_label[f] = region[static_cast<size_t>(g.face_unit[f])];
    ctx.regions = regions_from_labels(face_label);
    rep["units"] = nu;
    report_region_stats(ctx.regions, rep);
    write_region_outputs(kName, options(), ctx);
    ctx.step(kName, 1.0);
  }
};

}  // namespace
}  // namespace texdefrag::detectors

TEXDEFRAG_PLUGIN(texdefrag::detectors::AngleGrowingDetector)
