// The HTML report (`texdefrag report`, docs/report.md): one self-contained folder that opens from
// the file system (file://) in a browser, for a bench result or for one input with its outputs.
// Per model: an interactive 3D viewer showing the input and every configuration side by side with
// one shared camera (textured, chart-coloured or region-coloured), the atlas pages with chart
// outlines, and the metrics table with the best value of each metric marked; for a bench, also
// the summary table and the figures (Figures 16-20, rendered fidelity against MIP level, sweeps).
//
// The viewer is three.js (npm, bundled by scripts/install-npm.sh into one classic script) copied
// into the folder; model data are JavaScript files (file:// pages cannot fetch()), textures are
// data URLs inside them (WebGL refuses file:// images), geometry comes in chunks that the page
// adds one by one. A model above ReportOptions::max_faces gets no viewer and the page says so.
#pragma once

#include "texdefrag/eval/appearance.h"

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag::report {

using json = nlohmann::json;

struct ReportError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One output of a model: a configuration's (or another tool's) result.
struct ReportOutput {
  std::string label;                   ///< configuration label ("best", "mmethod_orig"...)
  std::string obj;                     ///< output OBJ path
  json metrics = json::object();       ///< derived metrics (bench::derived_metrics) for the table
  std::string config_path;             ///< pipeline configuration ("" for another tool)
  std::vector<std::string> overrides;  ///< its STAGE.OPTION=VALUE overrides
  json record;                         ///< model_from_files: a bench-like record (config, model, status, eval) for the figures; else null
};

struct ReportModel {
  std::string id;                      ///< model id (unique in the report)
  std::string input_obj;               ///< input OBJ path
  std::vector<ReportOutput> outputs;   ///< in column order
};

struct ReportOptions {
  std::string out_dir;                 ///< report folder (created; files in it are overwritten)
  std::string title = "texdefrag report";
  std::string bench_dir;               ///< bench results folder: figures/ and summary.json, or ""
  std::string figures_dir;             ///< PNG figures to embed; "" = bench_dir/figures (when bench_dir is set)
  std::string figures_note;            ///< shown instead of the figures when there are none (why not)
  size_t max_faces = 3000000;          ///< faces above which a model view is not exported (page says so)
  size_t chunk_faces = 60000;          ///< faces per geometry file (progressive loading), >= 1
  int texture_max = 2048;              ///< pixels: longer side of textures in the viewer, >= 16
  int atlas_max = 1024;                ///< pixels: longer side of the atlas page images, >= 16
  std::string three_js;                ///< the three.js bundle; "" = default_three_bundle()
};

/// What write_report wrote.
struct ReportSummary {
  std::string index_html;              ///< absolute path of index.html
  size_t models = 0, views = 0;        ///< models; (model, input or output) views exported
  size_t too_large = 0;                ///< views not exported for size
  size_t data_bytes = 0;               ///< bytes of data/ (geometry and textures)
};

/// The three.js bundle built by scripts/install-npm.sh (tools/node/build/three-bundle.js of the
/// source tree), or the TEXDEFRAG_THREE_JS environment variable when set.
std::string default_three_bundle();

/// The models of a bench results folder (results.jsonl): every model with its input and the
/// outputs of its successful records, labels in first-seen order, metrics = derived_metrics.
/// Throws ReportError when the folder has no results.jsonl or no successful record.
std::vector<ReportModel> models_from_bench(const std::string& results_dir);

/// One model from an input and outputs given as "LABEL=PATH" or "PATH" (label = the file's
/// folder name); each output is evaluated against the input (eval::compare_files, appearance
/// measures included, rendered views as `render` says) for the table; each output keeps its record
/// for write_run_figures. Throws ReportError on a malformed argument or a missing file.
ReportModel model_from_files(const std::string& input_obj, const std::vector<std::string>& outputs, size_t samples,
                             const eval::RenderFidelityOptions& render = {});

/// The figures of a single run (one model, its outputs from model_from_files): writes
/// `out_dir`/results.csv (bench::write_csv of the outputs' records), then runs eval/plots/plots.py
/// on it (bench::run_plots), which writes `out_dir`/summary.md and `out_dir`/figures/: Figures
/// 16-18 as one bar per output (distributions over one model), 19-20 per model, 21 (rendered
/// fidelity against viewing distance). Returns "" when the figures were written, else why not
/// (no Python or matplotlib: the report is still written, without figures).
/// Throws ReportError when an output has no record.
std::string write_run_figures(const ReportModel& model, const std::string& out_dir);

/// Writes the report folder: index.html, lib/ (three.js bundle, viewer.js, report.css), data/
/// (geometry and textures as JS), atlas/ (page images with chart outlines), figures/ (copied
/// from figures_dir, or bench_dir/figures), thumbs/ (left for the browser check's screenshots).
/// Throws ReportError (missing three.js bundle, unwritable folder) or the readers' errors naming
/// the file.
ReportSummary write_report(const std::vector<ReportModel>& models, const ReportOptions& options);

}  // namespace texdefrag::report
