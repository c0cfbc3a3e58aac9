// The report folder: data of every model view, atlas images, and index.html with the viewer,
// the metrics tables (best value marked) and the figures.
#include "export.h"
#include "report_assets.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/bench.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

namespace fs = std::filesystem;

namespace texdefrag::report {
namespace {

/// Rows of the metrics tables: label, the output's derived metric, the input's (or ""), format.
struct Row {
  const char* label;
  const char* out;
  const char* in;
  char kind;  // '%': fraction shown in percent, 'd': dB, 'i': integer, 'g': number
};

const Row kRows[] = {
    {"charts", "charts_out", "charts_in", 'i'},
    {"chart count reduction", "chart_reduction", "", '%'},
    {"UV border length reduction", "uv_border_reduction", "", '%'},
    {"3D seam length reduction", "seam_3d_reduction", "", '%'},
    {"ARAP distortion", "distortion_arap", "", 'g'},
    {"flipped faces", "flipped_faces", "", 'i'},
    {"lost faces", "lost_faces", "", 'i'},
    {"texture megapixels change", "texture_mp_change", "", '%'},
    {"texture bytes change", "texture_bytes_change", "", '%'},
    {"vertex replication V2/V3", "replication_out", "replication_in", 'g'},
    {"packing efficiency", "packing_efficiency_out", "", '%'},
    {"UV overlaps", "uv_overlaps_out", "", 'i'},
    {"texture PSNR (surface samples)", "psnr_db", "", 'd'},
    {"copied without resampling", "copied_fraction", "", '%'},
    {"texel clashes, MIP level 2", "clash_fraction_l2_out", "clash_fraction_l2_in", '%'},
    {"texel clashes, MIP level 4", "clash_fraction_l4_out", "clash_fraction_l4_in", '%'},
    {"seam colour discrepancy, MIP level 0 (RGB levels)", "seam_colour_out", "seam_colour_in", 'g'},
    {"seam colour discrepancy, MIP level 2", "seam_colour_l2_out", "seam_colour_l2_in", 'g'},
    {"seam colour discrepancy, MIP level 4", "seam_colour_l4_out", "seam_colour_l4_in", 'g'},
    {"rendered PSNR vs prefiltered input, distance step 0 (render size S)", "rendered_psnr_l0", "input_rendered_psnr_l0", 'd'},
    {"rendered PSNR, step 1 (S / 2)", "rendered_psnr_l1", "input_rendered_psnr_l1", 'd'},
    {"rendered PSNR, step 2 (S / 4)", "rendered_psnr_l2", "input_rendered_psnr_l2", 'd'},
    {"rendered PSNR, step 3 (S / 8)", "rendered_psnr_l3", "input_rendered_psnr_l3", 'd'},
    {"rendered PSNR, step 4 (S / 16)", "rendered_psnr_l4", "input_rendered_psnr_l4", 'd'},
    {"rendered SSIM, step 2", "rendered_ssim_l2", "input_rendered_ssim_l2", 'g'},
    {"rendered SSIM, step 4", "rendered_ssim_l4", "input_rendered_ssim_l4", 'g'},
    {"time (s)", "time_s", "", 'g'},
    {"peak memory (MiB)", "peak_rss_mb", "", 'g'},
};

std::string html(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      default: r += c;
    }
  }
  return r;
}

/// A metric value: a number, +-infinity (JSON "inf" strings or a null PSNR are not numbers here),
/// or NaN when absent.
double value_of(const json& metrics, const std::string& key) {
  if (key.empty() || !metrics.contains(key)) return std::nan("");
  const json& v = metrics[key];
  if (v.is_number()) return v.get<double>();
  if (v.is_string() && v.get<std::string>() == "inf") return HUGE_VAL;
  return std::nan("");
}

std::string format(double v, char kind) {
  if (std::isnan(v)) return "&ndash;";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  switch (kind) {
    case '%': std::snprintf(buf, sizeof buf, "%.1f%%", 100 * v); break;
    case 'd': std::snprintf(buf, sizeof buf, "%.2f dB", v); break;
    case 'i': std::snprintf(buf, sizeof buf, "%.0f", v); break;
    default: std::snprintf(buf, sizeof buf, "%.4g", v);
  }
  return buf;
}

/// One metrics table: a row per kRows entry, an input column, a column per label; the best
/// finite value of each row (by the metric's direction) marked.
std::string metrics_table(const std::vector<std::string>& labels, const std::vector<json>& values, const json& input_values) {
  std::ostringstream s;
  s << "<table class=\"metrics\"><tr><th>metric</th><th>input</th>";
  for (const std::string& l : labels) s << "<th>" << html(l) << "</th>";
  s << "</tr>\n";
  for (const Row& r : kRows) {
    std::vector<double> v;
    bool any = false;
    for (const json& m : values) {
      v.push_back(value_of(m, r.out));
      any = any || !std::isnan(v.back());
    }
    if (!any) continue;
    const int dir = bench::metric_direction(r.out);
    double best = std::nan("");
    if (dir != 0)
      for (double x : v)
        if (!std::isnan(x) && (std::isnan(best) || (dir > 0 ? x > best : x < best))) best = x;
    s << "<tr><td>" << r.label << "</td><td class=\"input\">" << format(value_of(input_values, r.in), r.kind) << "</td>";
    for (double x : v) s << "<td" << (!std::isnan(best) && x == best && v.size() > 1 ? " class=\"best\"" : "") << ">" << format(x, r.kind) << "</td>";
    s << "</tr>\n";
  }
  s << "</table>\n";
  return s.str();
}

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  if (n % 2) return v[n / 2];
  if (std::isinf(v[n / 2 - 1]) && v[n / 2 - 1] == v[n / 2]) return v[n / 2];
  return 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// The regions of the input: the detector of the first output whose configuration has one.
std::vector<int> input_regions(const TexturedMesh& in, const ReportModel& m, std::string& note) {
  for (const ReportOutput& o : m.outputs) {
    if (o.config_path.empty() || !fs::exists(o.config_path)) continue;
    try {
      std::vector<int> r = bench::detect_regions(in, o.config_path, o.overrides, m.input_obj);
      if (!r.empty()) {
        note = "regions: the detector of " + o.label;
        return r;
      }
    } catch (const std::exception& e) {
      note = "regions unavailable: " + std::string(e.what());
      return {};
    }
  }
  note = "regions: no configuration with a detector";
  return {};
}

struct LoadedView {
  TexturedMesh mesh;
  std::vector<int> chart, region;
};

LoadedView load_view(const std::string& obj) {
  LoadedView v;
  v.mesh = eval::canonical_pages(read_obj(obj));
  const Topology topo = build_topology(v.mesh);
  v.chart = build_charts(v.mesh, topo).atlas.face_chart;
  return v;
}

/// The figures (plots.py's PNGs of figures_dir, or bench_dir/figures), copied into root/figures
/// unless they are there already, and their HTML; the note when there is none.
std::string figures_section(const ReportOptions& o, const fs::path& root) {
  fs::path dir = o.figures_dir;
  if (dir.empty() && !o.bench_dir.empty()) dir = fs::path(o.bench_dir) / "figures";
  std::vector<std::string> figures;
  if (!dir.empty() && fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".png") figures.push_back(e.path().filename().string());
  std::sort(figures.begin(), figures.end());
  std::ostringstream s;
  if (figures.empty()) {
    if (!o.figures_note.empty()) s << "<h2>Figures</h2>\n<p class=\"note\">" << html(o.figures_note) << "</p>\n";
    return s.str();
  }
  const bool same = fs::exists(root / "figures") && fs::equivalent(dir, root / "figures");
  s << "<h2>Figures</h2>\n<div class=\"figures\">";
  for (const std::string& f : figures) {
    if (!same) fs::copy_file(dir / f, root / "figures" / f, fs::copy_options::overwrite_existing);
    s << "<a href=\"figures/" << html(f) << "\"><img src=\"figures/" << html(f) << "\" alt=\"" << html(f) << "\"></a>";
  }
  s << "</div>\n";
  return s.str();
}

/// Creates the report folder `o.out_dir` (lib, data, atlas, figures, thumbs) with the viewer's
/// files; returns its absolute path. Throws ReportError when the three.js bundle is missing or an
/// option is out of range (before anything is written). An existing thumbs/thumbs.js is kept.
fs::path prepare_report_folder(const ReportOptions& o) {
  const std::string three = o.three_js.empty() ? default_three_bundle() : o.three_js;
  if (three.empty() || !fs::is_regular_file(three))
    throw ReportError("three.js bundle not found ('" + three + "'): run scripts/install-npm.sh (or set TEXDEFRAG_THREE_JS)");
  if (o.chunk_faces < 1 || o.texture_max < 16 || o.atlas_max < 16) throw ReportError("report options out of range");
  const fs::path root = fs::absolute(o.out_dir);
  for (const char* d : {"lib", "data", "atlas", "figures", "thumbs"}) fs::create_directories(root / d);
  fs::copy_file(three, root / "lib" / "three.js", fs::copy_options::overwrite_existing);
  write_text((root / "lib" / "viewer.js").string(), kViewerJs);
  write_text((root / "lib" / "report.css").string(), kReportCss);
  // The browser check (--check) rewrites thumbs/thumbs.js with the screenshots it took; kept when
  // a report is rewritten over an earlier one.
  if (!fs::exists(root / "thumbs" / "thumbs.js")) write_text((root / "thumbs" / "thumbs.js").string(), "TD.thumbs = {};\n");
  return root;
}

/// What write_report gathers over the models: the summary, the viewer manifest, the models' HTML
/// sections, and per label ("input" and each output label) each metric's values over the models.
struct ReportState {
  ReportSummary sum;
  json manifest;
  std::ostringstream body;
  std::vector<std::string> all_labels;  // output labels, in the order first seen
  std::map<std::string, std::map<std::string, std::vector<double>>> per_label;  // label -> metric -> values
};

/// The frame of one model's views: the input's bounding box over its finite positions (every view
/// is centred the same way); both corners zero when no position is finite.
struct ModelFrame {
  Vec3 lo, hi;
};

/// The frame of `mesh`'s views (ModelFrame).
ModelFrame model_frame(const TexturedMesh& mesh) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& p : mesh.positions)
    if (p.allFinite()) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (hi.x() < lo.x()) lo = hi = Vec3::Zero();
  return {lo, hi};
}

/// Exports view `vi` of model `mi` (0: the input `in`; k > 0: output k - 1) through `eo`: its data
/// files (input regions carried to output faces by matched 3D triangles), its entry appended to
/// jm["views"] and its atlas pages as one <figure> appended to `atlas`; counted in `sum`.
void export_model_view(const ReportModel& m, size_t mi, size_t vi, const LoadedView& in, const std::vector<int>& regions,
                       const ExportOptions& eo, const fs::path& root, int atlas_max, ReportSummary& sum, json& jm,
                       std::ostringstream& atlas) {
  const bool is_input = vi == 0;
  const std::string label = is_input ? "input" : m.outputs[vi - 1].label;
  LoadedView out;
  const LoadedView& v = is_input ? in : (out = load_view(m.outputs[vi - 1].obj), out);
  ViewData vd;
  vd.key = "m" + std::to_string(mi) + "v" + std::to_string(vi);
  vd.mesh = &v.mesh;
  vd.face_chart = v.chart;
  if (!regions.empty()) {
    if (is_input) {
      vd.face_region = regions;
    } else {  // each output face takes the region of its input face (matched by 3D triangle)
      const eval::FaceMatch match = eval::match_faces(in.mesh, v.mesh);
      vd.face_region.assign(v.mesh.faces.size(), -1);
      for (size_t f = 0; f < v.mesh.faces.size(); ++f)
        if (match.input_of_output[f] >= 0) vd.face_region[f] = regions[static_cast<size_t>(match.input_of_output[f])];
    }
  }
  const ViewStats st = export_view(vd, eo);
  sum.views += st.too_large ? 0 : 1;
  sum.too_large += st.too_large ? 1 : 0;
  sum.data_bytes += st.bytes;
  jm["views"].push_back({{"key", vd.key}, {"label", label}, {"faces", st.faces}, {"pages", st.pages},
                         {"chunks", st.chunks}, {"too_large", st.too_large}, {"regions", !regions.empty()},
                         {"charts", v.chart.empty() ? 0 : 1 + *std::max_element(v.chart.begin(), v.chart.end())}});
  atlas << "<figure><figcaption>" << html(label) << "</figcaption>";
  for (const std::string& p : write_atlas_pages(v.mesh, v.chart, (root / "atlas" / vd.key).string(), atlas_max)) {
    const std::string rel = "atlas/" + fs::path(p).filename().string();
    atlas << "<a href=\"" << rel << "\"><img loading=\"lazy\" src=\"" << rel << "\" alt=\"" << html(label) << " atlas\"></a>";
  }
  atlas << "</figure>";
}

/// Adds model `mi` to `st`: every view exported (export_model_view), its manifest entry, its HTML
/// section (metrics table, atlas pages) and its metric values per label.
void add_model(const ReportModel& m, size_t mi, const fs::path& root, const ReportOptions& o, ReportState& st) {
  const LoadedView in = load_view(m.input_obj);
  std::string region_note;
  const std::vector<int> regions = input_regions(read_obj(m.input_obj), m, region_note);
  const auto [lo, hi] = model_frame(in.mesh);
  ExportOptions eo;
  eo.data_dir = (root / "data").string();
  eo.centre = 0.5 * (lo + hi);
  eo.max_faces = o.max_faces, eo.chunk_faces = o.chunk_faces, eo.texture_max = o.texture_max;
  json jm = {{"id", m.id}, {"index", mi}, {"radius", 0.5 * (hi - lo).norm()}, {"views", json::array()}};
  std::ostringstream atlas;
  std::vector<std::string> labels;
  std::vector<json> values;
  json input_values = m.outputs.empty() ? json::object() : m.outputs.front().metrics;
  for (size_t vi = 0; vi <= m.outputs.size(); ++vi) {
    export_model_view(m, mi, vi, in, regions, eo, root, o.atlas_max, st.sum, jm, atlas);
    if (vi == 0) continue;
    const std::string& label = m.outputs[vi - 1].label;
    labels.push_back(label);
    values.push_back(m.outputs[vi - 1].metrics);
    if (std::find(st.all_labels.begin(), st.all_labels.end(), label) == st.all_labels.end()) st.all_labels.push_back(label);
    for (const Row& r : kRows) st.per_label[label][r.out].push_back(value_of(m.outputs[vi - 1].metrics, r.out));
  }
  for (const Row& r : kRows)
    if (*r.in) st.per_label["input"][r.out].push_back(value_of(input_values, r.in));
  st.manifest["models"].push_back(jm);
  st.body << "<section class=\"model\" id=\"model-" << mi << "\"><h2>" << html(m.id) << "</h2>\n"
          << "<p class=\"note\">" << html(m.input_obj) << " &mdash; " << in.mesh.faces.size() << " faces; " << html(region_note)
          << "</p>\n<button class=\"open-viewer\" data-model=\"" << html(m.id) << "\">Show in the 3D viewer</button>\n"
          << "<div class=\"viewer-slot\"></div>\n<h3>Metrics</h3>\n" << metrics_table(labels, values, input_values)
          << "<h3>Atlas pages (chart outlines in yellow)</h3>\n<div class=\"atlas\">" << atlas.str() << "</div></section>\n";
  ++st.sum.models;
}

/// The summary over `num_models` models (only when more than one): medians per label of st.per_label.
std::string summary_section(size_t num_models, ReportState& st) {
  std::ostringstream head;
  if (num_models > 1) {
    std::vector<json> med;
    for (const std::string& l : st.all_labels) {
      json j = json::object();
      for (const Row& r : kRows) {
        const double x = median(st.per_label[l][r.out]);
        if (!std::isnan(x)) j[r.out] = std::isinf(x) ? json("inf") : json(x);
      }
      med.push_back(j);
    }
    json in_med = json::object();
    for (const Row& r : kRows)
      if (*r.in) {
        const double x = median(st.per_label["input"][r.out]);
        if (!std::isnan(x)) in_med[r.in] = std::isinf(x) ? json("inf") : json(x);
      }
    head << "<h2>Summary: medians over " << num_models << " models</h2>\n" << metrics_table(st.all_labels, med, in_med);
  }
  return head.str();
}

/// index.html: the page head (manifest, scripts), the model links, the viewer, then `head`
/// (summary and figures) and the models' sections of `st`.
std::string index_page(const std::vector<ReportModel>& models, const ReportOptions& o, const ReportState& st,
                       const std::string& head) {
  std::ostringstream page;
  page << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << html(o.title) << "</title>\n"
       << "<link rel=\"stylesheet\" href=\"lib/report.css\">\n"
       << "<script>window.TD = {manifest: " << st.manifest.dump() << "};</script>\n"
       << "<script src=\"lib/three.js\"></script>\n<script src=\"thumbs/thumbs.js\"></script>\n"
       << "<script src=\"lib/viewer.js\"></script>\n</head><body>\n"
       << "<h1>" << html(o.title) << "</h1>\n<p class=\"note\">" << models.size() << " models; input and "
       << st.all_labels.size() << " configurations. Opens from the file system; three.js is in lib/.</p>\n"
       << "<nav class=\"models\">";
  for (size_t mi = 0; mi < models.size(); ++mi)
    page << "<a href=\"#model-" << mi << "\" data-model=\"" << html(models[mi].id) << "\">" << html(models[mi].id) << "</a>";
  page << "</nav>\n"
       << "<div id=\"viewer\" hidden><div id=\"viewer-labels\"></div><div id=\"viewer-bar\"><span id=\"viewer-modes\">"
       << "<button data-mode=\"texture\" class=\"on\">textured</button><button data-mode=\"chart\">charts</button>"
       << "<button data-mode=\"region\">regions</button></span><button id=\"viewer-reset\">reset camera</button>"
       << "<span id=\"viewer-status\">loading&hellip;</span></div>"
       << "<p class=\"note\">Drag to orbit, right-drag to pan, wheel to zoom; every view shares the camera.</p></div>\n"
       << head << st.body.str() << "</body></html>\n";
  return page.str();
}

}  // namespace

ReportSummary write_report(const std::vector<ReportModel>& models, const ReportOptions& o) {
  const fs::path root = prepare_report_folder(o);
  ReportState st;
  st.manifest = {{"max_faces", o.max_faces}, {"models", json::array()}};
  for (size_t mi = 0; mi < models.size(); ++mi) add_model(models[mi], mi, root, o, st);
  std::string head = summary_section(models.size(), st);
  head += figures_section(o, root);
  write_text((root / "index.html").string(), index_page(models, o, st, head));
  st.sum.index_html = (root / "index.html").string();
  return st.sum;
}

}  // namespace texdefrag::report
