// Batch runs of the evaluation harness (`texdefrag bench`, docs/bench.md): every configuration on
// every model, each run in its own child process (so peak memory per stage is the run's own), each
// output compared with its input by the metrics library (eval/metrics), one JSON record per
// (configuration, model) pair in RESULTS/results.jsonl, flattened into RESULTS/results.csv, with
// per-configuration medians and means in RESULTS/summary.json.
//
// Pseudo-configurations: outputs of another tool (e.g. the M-method's own program,
// ../shared/data/mmethod_outputs) are evaluated the same way under the tool's name.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag::bench {

using json = nlohmann::json;

/// Bad bench arguments (unknown data folder, malformed manifest or --sweep, duplicate labels...).
struct BenchError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// ---------------------------------------------------------------------------------------------
// Models

struct BenchModel {
  std::string id;    ///< unique name in the batch (the OBJ stem, or the manifest's "name"/"id")
  std::string path;  ///< absolute path of the OBJ
  json meta = json::object();  ///< scalar fields of the manifest entry (archetype, faces...), else {}
};

/// The models of a data set, sorted by id.
/// @param data     a folder (every *.obj under it, recursively, except files under `exclude_dir`
///                 and outputs of texdefrag, i.e. OBJs with a sibling <stem>.report.json), or a
///                 manifest.json {"models": [{"path" or "obj": ..., "name" or "id": ..., ...}]}
///                 whose relative paths are relative to the manifest's folder.
/// @param exclude_dir  a folder whose contents are never models (the results folder); may be "".
/// Ids are OBJ stems; when two stems collide, the path relative to the folder (without ".obj",
/// '/' replaced by '_') is used for all of them. Throws BenchError when `data` does not exist,
/// the manifest is malformed or names a missing file, or no model is found.
std::vector<BenchModel> discover_models(const std::string& data, const std::string& exclude_dir = "");

// ---------------------------------------------------------------------------------------------
// Configurations

struct BenchConfig {
  std::string label;       ///< "<config stem>" or "<config stem>[option=value,...]" (sets, sweeps)
  std::string base;        ///< config stem, or the external tool's name
  std::string path;        ///< absolute path of the config file; "" for an external tool
  std::vector<std::string> overrides;  ///< STAGE.OPTION=VALUE strings passed to load_config
  std::string sweep_key;   ///< the swept STAGE.OPTION, "" when not swept
  std::string sweep_value; ///< its value for this configuration, "" when not swept
  std::string external_dir;  ///< external tool: folder of its outputs; "" for a pipeline config
  bool external() const { return !external_dir.empty(); }
};

/// Expands configuration files, overrides and sweeps into the batch's configurations.
/// @param config_paths  pipeline configuration files (labels are their stems; must be distinct)
/// @param sets    STAGE.OPTION=VALUE overrides applied to every configuration (part of the label)
/// @param sweeps  STAGE.OPTION=V1,V2,... ; one configuration per value (several sweeps: every
///                combination, in order). Label: "<stem>[option=value]" with option the last
///                dot-separated part of STAGE.OPTION (the sets come first inside the brackets).
/// @param externals  NAME=DIR of another tool's outputs (DIR must exist; NAME must not collide)
/// Throws BenchError on a malformed set/sweep/external or a duplicate label. Does not validate
/// the configurations themselves (validate_configs does).
std::vector<BenchConfig> expand_configs(const std::vector<std::string>& config_paths,
                                        const std::vector<std::string>& sets,
                                        const std::vector<std::string>& sweeps,
                                        const std::vector<std::string>& externals);

/// Loads every pipeline configuration with its overrides (texdefrag::load_config); throws
/// BenchError listing every invalid one with its errors.
void validate_configs(const std::vector<BenchConfig>& configs);

/// The output of an external tool for a model, or "" when there is none. Looked up in `dir`, in
/// order: <stem>/<stem>_defrag.obj, <stem>/<stem>*.obj, <stem>_defrag.obj, <stem>*.obj,
/// <any>/<stem>_defrag.obj, <stem>/ holding exactly one *.obj; where "<stem>*" means the stem
/// followed by nothing or by a non-alphanumeric character (t016_L1 never matches t016_L18).
/// @param model_stem  the stem of the input OBJ (not the bench id).
std::string find_external_output(const std::string& dir, const std::string& model_stem);

/// Numbers of the M-method program's log.txt: every "Key number" line (InputCharts,
/// OutputCharts, InputUVLen, InputMP, ZeroResamplingFraction...) under its key, plus
/// processing_time_s ("Processing took X seconds"), packing_time_s ("Packed N charts in X
/// seconds"), optimization_time_s (the last "TOTAL ... X secs"), energy_before / energy_after
/// ("Atlas energy before/after optimization is X"), removed_duplicate_vertices and
/// removed_non_manifold_faces. Returns {} when the file cannot be read.
json parse_tool_log(const std::string& log_path);

// ---------------------------------------------------------------------------------------------
// Child processes

struct ChildResult {
  int exit_code = -1;        ///< exit status, or -1 when killed by a signal or not started
  int signal = 0;            ///< terminating signal, 0 when it exited
  bool timed_out = false;    ///< killed after the timeout
  std::string out, err;      ///< captured standard output and error
  double wall_s = 0;         ///< wall-clock seconds
  long max_rss_bytes = 0;    ///< the child's peak resident set size (getrusage), bytes
  std::string start_error;   ///< why the process could not be started, "" when it was
  bool ok() const { return start_error.empty() && exit_code == 0 && signal == 0 && !timed_out; }
  /// One-line description of a failure (exit code or signal, timeout, last lines of stderr).
  std::string describe() const;
};

/// Runs argv[0] with arguments argv[1..] (no shell), stdin from /dev/null, stdout and stderr
/// captured through files `capture_prefix`.stdout / .stderr (kept for inspection).
/// @param timeout_s  seconds before the child is killed (SIGKILL); 0 = no limit.
ChildResult run_child(const std::vector<std::string>& argv, const std::string& capture_prefix, double timeout_s = 0);

/// What run_plots wrote: `figures` when plots.py exited 0 (table and figures), else a message.
struct PlotsResult {
  bool figures = false;  ///< the figures were written
  std::string message;   ///< one line for the user: where they are, or why not (no script, no Python, no matplotlib)
  std::string out;       ///< plots.py's standard output
};

/// Runs eval/plots/plots.py (installed as share/texdefrag/plots/plots.py) under
/// python_executable() with `args` (--results DIR [--csv ...] [--figures ...] [--summary ...]);
/// its output is captured through `capture_prefix`. Never throws for a missing script, Python or
/// matplotlib: the message says which.
PlotsResult run_plots(const std::vector<std::string>& args, const std::string& capture_prefix);

// ---------------------------------------------------------------------------------------------
// Batch

struct BenchOptions {
  std::string data;                     ///< folder or manifest.json (discover_models)
  std::vector<std::string> configs;     ///< pipeline configuration files
  std::vector<std::string> sets;        ///< overrides for every configuration
  std::vector<std::string> sweeps;      ///< STAGE.OPTION=V1,V2,...
  std::vector<std::string> externals;   ///< NAME=DIR
  std::string out_dir;                  ///< results folder (created)
  int jobs = 1;                         ///< pairs run at once, >= 1
  int threads = -1;                     ///< each run's --threads (0 = every core); -1 = not passed
  size_t samples = 200000;              ///< texture fidelity samples per comparison
  bool texture = true;                  ///< compute texture fidelity
  bool retry_failed = false;            ///< re-run pairs whose existing record failed
  double timeout_s = 0;                 ///< per child process; 0 = none
  bool views = false;                   ///< also write chart-coloured page views (write_chart_views)
  std::string exe;                      ///< texdefrag executable for children; "" = /proc/self/exe
  /// Called (serialised, from worker threads) with one line per finished or skipped pair.
  std::function<void(const std::string&)> log;
};

struct BenchSummary {
  size_t pairs = 0;      ///< (configuration, model) pairs in this invocation
  size_t ran = 0;        ///< evaluated now, successfully
  size_t skipped = 0;    ///< already in results.jsonl
  size_t failed = 0;     ///< run or evaluation failed now (recorded)
  size_t missing = 0;    ///< external tool without an output for the model (recorded)
};

/// Runs the batch: for every configuration and model (in parallel, options.jobs at once) a child
/// `texdefrag run` into OUT/runs/<label>/<model>/, then a child evaluation of input vs output;
/// appends one record per pair to OUT/results.jsonl as soon as it is known, then rewrites
/// OUT/results.csv and OUT/summary.json from all records of results.jsonl (the last record of a
/// pair wins). Pairs already recorded are skipped (failed ones too unless retry_failed).
/// A failing pair is recorded with status "failed" and its error; it never stops the batch.
/// With options.views, every successful pair of the invocation without views gets
/// OUT/views/<label>/<model>/charts_page<k>.png, charts_3d.png (and regions_3d.png when the
/// configuration has a detector), and OUT/views/input/<model>/charts_page<k>.png, charts_3d.png.
/// Throws BenchError for bad arguments or invalid configurations (before running anything).
BenchSummary run_bench(const BenchOptions& options);

/// Distinct colour of a chart id for views (golden-ratio hue steps).
std::array<uint8_t, 3> chart_colour(int chart);

/// Chart-coloured views of the atlas pages of a model (the paper's Figures 13-14 style): each
/// textured face's UV triangle filled with its chart's colour (charts of core/charts.h, pages
/// canonicalised as in eval), background dark grey, scaled down so the longer side is at most
/// `max_size` pixels (faces smaller than a pixel still mark their centroid's pixel).
/// @param obj_path  the model (OBJ + MTL; page images are only stat'ed for their sizes)
/// @param prefix    output path prefix (its folder is created); writes <prefix>_page<k>.png for
///                  every page used by a face
/// @param max_size  pixels, >= 16
/// Returns the written paths. Throws ObjError/ImageError/BenchError naming the file.
std::vector<std::string> write_chart_views(const std::string& obj_path, const std::string& prefix, int max_size = 1024);

/// Oblique orthographic render (z up, azimuth 35 deg, elevation 40 deg) of `mesh`, flat-shaded
/// (two-sided Lambert + ambient), z-buffered, each face in chart_colour(face_colour[f]) (grey for
/// -1), light background, `size` pixels on the longer side.
/// @param face_colour  one colour id per face (chart or region)
/// @param size         pixels, >= 16
Image render_3d(const TexturedMesh& mesh, const std::vector<int>& face_colour, int size = 1024);

/// Writes render_3d of the model coloured by chart (core/charts.h) to `png_path` (folder created).
/// Returns png_path. Throws ObjError/ImageError naming the file.
std::string write_chart_render(const std::string& obj_path, const std::string& png_path, int size = 1024);

/// The configuration's regions on the model at `input_path`: the framework runs the configuration up
/// to its detector (run_pipeline with stop_after = "detector", in this process, same options and
/// checks as a run). Empty when the detector yields at most one region (no region constraint).
/// `mesh` must be the model read from input_path (its face count is checked).
/// Throws ConfigError/StageError/BenchError.
std::vector<int> detect_regions(const TexturedMesh& mesh, const std::string& config_path,
                                const std::vector<std::string>& overrides, const std::string& input_path);

/// detect_regions on the model, then render_3d coloured by region written to `png_path`. Returns ""
/// (writes nothing) when the detector yields at most one region.
/// Throws ConfigError/StageError/ObjError/BenchError.
std::string write_region_render(const std::string& obj_path, const std::string& config_path,
                                const std::vector<std::string>& overrides, const std::string& png_path,
                                int size = 1024);

/// Evaluates one pair in this process (the body of the evaluation child):
/// {"comparison": eval::to_json(compare_files(...)), "eval_time_s", "peak_rss_bytes"}.
/// Throws what compare_files throws.
json evaluate_pair(const std::string& input_obj, const std::string& output_obj, size_t samples, bool texture);

// ---------------------------------------------------------------------------------------------
// Tables

/// The derived per-record metrics used by the tables and plots (docs/bench.md), computed from a
/// record: chart_reduction, uv_border_reduction, seam_3d_reduction, distortion_arap, texture_mp_change,
/// replication_in/out, psnr_db, time_s, peak_rss_mb... Absent values are null.
json derived_metrics(const json& record);

/// Whether larger values of a derived metric are better (+1), smaller (-1), or neither (0).
int metric_direction(const std::string& name);

/// Reads results.jsonl: one record per pair key (the last one wins), in first-seen order.
/// Malformed lines are skipped and counted in `*bad_lines` when given.
std::vector<json> read_records(const std::string& jsonl_path, size_t* bad_lines = nullptr);

/// The resume key of a record: config label, model id and overrides.
std::string record_key(const json& record);

/// Writes the flattened CSV: fixed columns (config, base_config, kind, sweep_key, sweep_value,
/// model, status, error), the derived metrics, then every other leaf of the records sorted by its
/// dotted path. Strings are quoted when needed; null is empty; +infinity is "inf".
void write_csv(const std::vector<json>& records, const std::string& csv_path);

/// Per configuration label: counts by status and median/mean/min/max/n of each derived metric
/// over successful records; "winners": per metric with a direction, the label with the best median.
json summarize(const std::vector<json>& records);

}  // namespace texdefrag::bench
