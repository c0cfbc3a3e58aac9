// JSON and fixed-format text reports of the metrics (key names documented in docs/eval.md).
#include "texdefrag/eval/metrics.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <limits>

namespace texdefrag::eval {
namespace {

nlohmann::json num(double d) { return std::isfinite(d) ? nlohmann::json(d) : nlohmann::json(nullptr); }

std::string fmt(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char* format, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, format);
  std::vsnprintf(buf, sizeof buf, format, ap);
  va_end(ap);
  return buf;
}

std::string pct(double in, double out) {
  const double r = relative_change(in, out);
  return std::isfinite(r) ? fmt("%+.1f%%", 100.0 * r) : std::string("n/a");
}

std::string model_line(const char* label, const std::string& path, const ModelMetrics& m) {
  const std::string name = path.empty() ? std::string("(memory)") : std::filesystem::path(path).filename().string();
  return fmt("%-6s %s\n", label, name.c_str()) +
         fmt("  faces %zu  V3 %zu  V2 %zu  replication %.3f  charts %zu (non-zero area %zu)\n", m.faces, m.v3, m.v2,
             m.vertex_replication, m.charts, m.charts_nonzero) +
         fmt("  uv border %.1f texels  seam 3D %.3f (%zu edges)  pages %zu  %.3f MP  %llu bytes\n", m.uv_border_length,
             m.seam_length_3d, m.seam_edges, m.pages, m.megapixels, static_cast<unsigned long long>(m.page_bytes)) +
         fmt("  packing %.3f  uv overlaps %zu  non-manifold edges %zu  degenerate %zu  zero-area %zu\n",
             m.packing_efficiency, m.uv_overlaps, m.topology.non_manifold_edges, m.topology.degenerate_faces,
             m.topology.zero_area_faces);
}

}  // namespace

double relative_change(double in, double out) {
  return in != 0 ? (out - in) / in : std::numeric_limits<double>::quiet_NaN();
}

nlohmann::json to_json(const ModelMetrics& m) {
  nlohmann::json j;
  j["faces"] = m.faces;
  j["textured_faces"] = m.textured_faces;
  j["v3"] = m.v3;
  j["v2"] = m.v2;
  j["vertex_replication"] = num(m.vertex_replication);
  j["charts"] = m.charts;
  j["charts_nonzero_area"] = m.charts_nonzero;
  j["zero_area_charts"] = m.zero_area_charts;
  j["uv_border_length_texels"] = num(m.uv_border_length);
  j["seam_edges"] = m.seam_edges;
  j["seam_length_3d"] = num(m.seam_length_3d);
  j["pages"] = m.pages;
  j["megapixels"] = num(m.megapixels);
  j["page_bytes"] = m.page_bytes;
  j["missing_page_files"] = m.missing_page_files;
  j["uv_area_texels2"] = num(m.uv_area);
  j["page_area_texels2"] = num(m.page_area);
  j["packing_efficiency"] = num(m.packing_efficiency);
  j["uv_overlaps"] = m.uv_overlaps;
  const TopologyReport& t = m.topology;
  j["topology"] = {{"edges", t.edges},
                   {"boundary_edges", t.boundary_edges},
                   {"non_manifold_edges", t.non_manifold_edges},
                   {"non_manifold_vertices", t.non_manifold_vertices},
                   {"degenerate_faces", t.degenerate_faces},
                   {"zero_area_faces", t.zero_area_faces},
                   {"duplicate_faces", t.duplicate_faces}};
  return j;
}

/// The appearance measures (appearance.h) of a comparison into `j`: texel_clashes, seam_colour,
/// rendered (null when not computed).
static void appearance_json(const Comparison& c, nlohmann::json& j) {
  using json = nlohmann::json;
  auto clashes = [](const std::vector<ClashLevel>& v) {
    json a = json::array();
    for (const ClashLevel& l : v)
      a.push_back({{"level", l.level}, {"texels", l.texels}, {"used", l.used}, {"clashes", l.clashes}, {"fraction", num(l.fraction)}});
    return a;
  };
  j["texel_clashes"] = c.has_clashes ? json{{"input", clashes(c.clashes_input)}, {"output", clashes(c.clashes_output)}} : json(nullptr);
  auto seam = [](const SeamColourMetrics& s) {
    json levels = json::array();
    for (const SeamColourLevel& l : s.levels)
      levels.push_back({{"level", l.level}, {"mean", num(l.mean)}, {"rms", num(l.rms)}, {"max", num(l.max)}});
    return json{{"seam_edges", s.seam_edges}, {"samples", s.samples}, {"length_3d", num(s.length_3d)},
                {"mean", num(s.mean)}, {"rms", num(s.rms)}, {"max", num(s.max)}, {"levels", levels}};
  };
  j["seam_colour"] = c.has_seam_colour ? json{{"input", seam(c.seam_colour_input)}, {"output", seam(c.seam_colour_output)}} : json(nullptr);
  if (!c.has_rendered) {
    j["rendered"] = nullptr;
    return;
  }
  json levels = json::array();
  for (const RenderLevel& l : c.rendered.levels)
    levels.push_back({{"level", l.level}, {"size", l.size}, {"pixels", l.pixels},
                      {"input_psnr_db", num(l.input_psnr_db)}, {"input_ssim", num(l.input_ssim)},
                      {"output_psnr_db", num(l.output_psnr_db)}, {"output_ssim", num(l.output_ssim)},
                      {"pair_psnr_db", num(l.pair_psnr_db)}, {"pair_ssim", num(l.pair_ssim)}});
  j["rendered"] = {{"views", c.rendered.views}, {"size", c.rendered.size}, {"supersample", c.rendered.supersample},
                   {"levels", levels}};
}

nlohmann::json to_json(const Comparison& c) {
  nlohmann::json j;
  j["input"] = to_json(c.input);
  j["input"]["path"] = c.input_path;
  j["output"] = to_json(c.output);
  j["output"]["path"] = c.output_path;
  const ModelMetrics& a = c.input;
  const ModelMetrics& b = c.output;
  auto rel = [](double x, double y) { return num(relative_change(x, y)); };
  auto d = [](size_t v) { return static_cast<double>(v); };
  j["relative_change"] = {
      {"faces", rel(d(a.faces), d(b.faces))},
      {"v3", rel(d(a.v3), d(b.v3))},
      {"v2", rel(d(a.v2), d(b.v2))},
      {"vertex_replication", rel(a.vertex_replication, b.vertex_replication)},
      {"charts", rel(d(a.charts), d(b.charts))},
      {"charts_nonzero_area", rel(d(a.charts_nonzero), d(b.charts_nonzero))},
      {"uv_border_length_texels", rel(a.uv_border_length, b.uv_border_length)},
      {"seam_length_3d", rel(a.seam_length_3d, b.seam_length_3d)},
      {"megapixels", rel(a.megapixels, b.megapixels)},
      {"page_bytes", rel(static_cast<double>(a.page_bytes), static_cast<double>(b.page_bytes))},
      {"packing_efficiency", rel(a.packing_efficiency, b.packing_efficiency)},
      {"uv_overlaps", rel(d(a.uv_overlaps), d(b.uv_overlaps))}};
  const FaceMatch& m = c.match;
  j["matching"] = {{"input_faces", m.output_of_input.size()},
                   {"output_faces", m.input_of_output.size()},
                   {"matched", m.matched},
                   {"lost", m.lost},
                   {"added", m.added},
                   {"lost_degenerate", m.lost_degenerate},
                   {"lost_zero_area", m.lost_zero_area},
                   {"lost_non_manifold", m.lost_non_manifold},
                   {"lost_other", m.lost_other},
                   {"exact_positions", m.exact_positions},
                   {"snapped_positions", m.snapped_positions},
                   {"moved_positions", m.moved_positions}};
  const DistortionMetrics& ds = c.distortion;
  j["distortion"] = {{"faces", ds.faces},
                     {"arap", num(ds.arap)},
                     {"symmetric_dirichlet", num(ds.symmetric_dirichlet)},
                     {"flipped", ds.flipped},
                     {"mirrored_charts", ds.mirrored_charts},
                     {"mirrored_faces", ds.mirrored_faces},
                     {"zero_area_input", ds.zero_area_input},
                     {"weight_texels2", num(ds.weight)}};
  if (c.has_fidelity) {
    const FidelityMetrics& f = c.fidelity;
    j["fidelity"] = {{"faces", f.faces},
                     {"samples", f.samples},
                     {"weight_texels2", num(f.weight)},
                     {"mse", num(f.mse)},
                     {"psnr_db", num(f.psnr_db)},
                     {"copied_fraction", num(f.copied_fraction)},
                     {"rigid_fraction", num(f.rigid_fraction)},
                     {"rigid_faces", f.rigid_faces}};
  } else {
    j["fidelity"] = nullptr;
  }
  appearance_json(c, j);
  return j;
}

std::string summary(const Comparison& c) {
  const ModelMetrics& a = c.input;
  const ModelMetrics& b = c.output;
  std::string s = model_line("input", c.input_path, a) + model_line("output", c.output_path, b);
  s += fmt("change faces %s  charts %s  uv border %s  seam 3D %s  replication %s  MP %s  bytes %s\n",
           pct(static_cast<double>(a.faces), static_cast<double>(b.faces)).c_str(),
           pct(static_cast<double>(a.charts), static_cast<double>(b.charts)).c_str(),
           pct(a.uv_border_length, b.uv_border_length).c_str(), pct(a.seam_length_3d, b.seam_length_3d).c_str(),
           pct(a.vertex_replication, b.vertex_replication).c_str(), pct(a.megapixels, b.megapixels).c_str(),
           pct(static_cast<double>(a.page_bytes), static_cast<double>(b.page_bytes)).c_str());
  const FaceMatch& m = c.match;
  s += fmt("match  matched %zu  lost %zu (degenerate %zu, zero-area %zu, non-manifold %zu, other %zu)  added %zu\n",
           m.matched, m.lost, m.lost_degenerate, m.lost_zero_area, m.lost_non_manifold, m.lost_other, m.added);
  s += fmt("       positions exact %zu  snapped %zu  moved %zu\n", m.exact_positions, m.snapped_positions,
           m.moved_positions);
  const DistortionMetrics& d = c.distortion;
  s += fmt("distortion  ARAP %.5f  symmetric Dirichlet %.5f  flipped %zu  over %zu faces (zero UV area %zu, "
           "mirrored charts %zu)\n",
           d.arap, d.symmetric_dirichlet, d.flipped, d.faces, d.zero_area_input, d.mirrored_charts);
  if (c.has_fidelity) {
    const FidelityMetrics& f = c.fidelity;
    const std::string psnr = std::isfinite(f.psnr_db) ? fmt("%.2f dB", f.psnr_db) : std::string("inf (identical)");
    s += fmt("fidelity  PSNR %s  over %zu samples on %zu faces  copied %.1f%%  rigid faces %.1f%% of area\n",
             psnr.c_str(), f.samples, f.faces, 100.0 * f.copied_fraction, 100.0 * f.rigid_fraction);
  }
  if (c.has_clashes) {
    s += "texel clashes (input -> output, share of used texels)";
    for (size_t l = 0; l < c.clashes_input.size() && l < c.clashes_output.size(); ++l)
      s += fmt("  L%zu %.1f%% -> %.1f%%", l, 100.0 * c.clashes_input[l].fraction, 100.0 * c.clashes_output[l].fraction);
    s += "\n";
  }
  if (c.has_seam_colour) {
    s += fmt("seam colour  mean %.2f -> %.2f  rms %.2f -> %.2f (RGB levels, %zu -> %zu seam edges)\n",
             c.seam_colour_input.mean, c.seam_colour_output.mean, c.seam_colour_input.rms, c.seam_colour_output.rms,
             c.seam_colour_input.seam_edges, c.seam_colour_output.seam_edges);
    s += "seam colour per MIP level (mean, input -> output)";
    const auto& a = c.seam_colour_input.levels;
    const auto& b = c.seam_colour_output.levels;
    for (size_t l = 0; l < a.size() && l < b.size(); ++l) s += fmt("  L%zu %.2f -> %.2f", l, a[l].mean, b[l].mean);
    s += "\n";
  }
  if (c.has_rendered) {
    s += fmt("rendered (%d views from %d px down; PSNR vs the prefiltered input: input / output; SSIM output)",
             c.rendered.views, c.rendered.size);
    for (const RenderLevel& l : c.rendered.levels) {
      auto db = [](double v) { return std::isfinite(v) ? fmt("%.1f", v) : std::string("inf"); };
      s += fmt("  %dpx %s/%s %.3f", l.size, db(l.input_psnr_db).c_str(), db(l.output_psnr_db).c_str(), l.output_ssim);
    }
    s += "\n";
  }
  return s;
}

}  // namespace texdefrag::eval
