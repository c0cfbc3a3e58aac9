// The JSON-configured pipeline: read -> topology -> charts -> detector -> merger -> packer ->
// texture resampling -> write, with one run report.
//
// Config file (configs/*.json):
//   {
//     "description": "free text",                                      (optional)
//     "detector": {"type": "detectors.none", ...options},              (default detectors.none)
//     "merger":   {"type": "mergers.none", ...options},                (default mergers.none)
//     "packer":   {"type": "packers.shelf", ...options},               (default packers.shelf)
//     "texture":  {...options of texture.resample},                     (optional)
//     "output":   {...options of writers.obj}                           (optional)
//   }
// The whole file is validated before any mesh is read; every error names its key
// ("packer.gutter: = -1 outside [0, 64]") and all errors are reported together.
#pragma once

#include "texdefrag/core/distortion.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/stage/stage.h"

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

/// One or more configuration errors; what() lists them one per line.
struct ConfigError : std::runtime_error {
  explicit ConfigError(std::vector<std::string> errs);
  std::vector<std::string> errors;
};

struct StageConfig {
  std::string section;  ///< "detector", "merger", "packer"
  std::string type;     ///< qualified stage name
  Options options;      ///< validated, defaults filled in
};

struct PipelineConfig {
  std::string origin;   ///< file path or "<string>"
  StageConfig detector, merger, packer;
  Options texture;      ///< texture.resample options
  Options output;       ///< writers.obj options
  json effective;       ///< the configuration after overrides and defaults (for the report)
  /// Files the stages read besides the model (values of input-path options, e.g. a label file):
  /// protected from every write, as the model's own files are.
  std::vector<std::string> input_files;
};

/// Declarations of the framework's own configurable steps (listed by `texdefrag plugins`).
const StageInfo& texture_stage_info();  ///< "texture.resample"
const StageInfo& writer_stage_info();   ///< "writers.obj"

/// Parses and validates a configuration. `overrides` are "SECTION_OR_STAGE.OPTION=VALUE" strings
/// (e.g. "packer.gutter=4" or "packers.shelf.gutter=4"; VALUE is JSON, or a bare string).
/// Throws ConfigError listing every problem. Loads plugins from the registry on first use.
PipelineConfig parse_config(const json& config, const std::string& origin,
                            const std::vector<std::string>& overrides = {});
/// Reads and parses a config file; JSON syntax errors name the file, line and column.
PipelineConfig load_config(const std::string& path, const std::vector<std::string>& overrides = {});

struct RunOptions {
  std::string input;        ///< input OBJ
  std::string output_dir;   ///< created if missing; must not be the input's folder
  ProgressFn progress;      ///< may be empty
  bool write_output = true; ///< false: run the stages and report, write nothing
  /// false: a file the input references that does not exist (an OSGB PagedLOD child) is an error
  /// naming it and its parent; true: listed in the report's read node (`missing_files`) and the
  /// model is processed (for pyramids delivered without their finest level).
  bool allow_missing_children = false;
  /// A model already read (e.g. several glTF files sharing one atlas, read as one): when set, the
  /// pipeline does not read `input` (still used for the report and the output stem) and `format`
  /// must be the format that read it.
  std::shared_ptr<const LoadedModel> model;
  const ModelFormat* format = nullptr;
  /// When set, writes the output instead of format.write into its own OutputSet under output_dir,
  /// and the report file is left to the caller (a production writes every tile into one set).
  std::function<WriteResult(const LoadedModel&, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                            const PageWriteOptions&)> write;
  /// Called after each configured stage ("detector", "merger", "packer") with the context as the
  /// stage left it (mesh, regions, atlas, layout), after the framework's checks. May be empty.
  std::function<void(const std::string& section, const StageContext& ctx)> on_stage;
  /// Section after which the run stops and returns the report so far ("" = run everything); no
  /// file is written when the run stops early. E.g. "detector" to get the regions (eval views).
  std::string stop_after;
};

/// Runs the pipeline. Returns the run report (also written as OUTDIR/<stem>.report.json).
/// Every file, the stages' side outputs included, goes through one OutputSet (io/output_set.h):
/// the input's files (OBJ, MTLs, pages, input-path options) are never written, the set appears
/// when the run succeeds, the report last, and two runs into one folder exclude each other.
/// Throws ObjError/ImageError/StageError/ConfigError/OutputError on failure; never leaves a file
/// under a final name when it throws.
json run_pipeline(const PipelineConfig& config, const RunOptions& options);

/// The framework's own figures of a merger's result, as run_pipeline writes them into the merger's
/// report node: charts_in, charts_out, distortion_arap and flipped_faces (core/distortion.h).
/// Stages never write these keys (run_pipeline refuses a stage that does). Returns the measure.
DistortionSummary report_merger_figures(const TexturedMesh& mesh, int charts_in, const Atlas& atlas, json& node);

/// The merger's contract on distortion, checked by run_pipeline after every merger: no flipped face
/// (the input, measured against itself, has none) and, when the merger declares a budget
/// (Merger::distortion_budget), the ARAP distortion within it (up to a relative 1e-9: the merger
/// adds its sums in another order). Throws StageError naming the stage and the figures.
void check_merger_distortion(const std::string& stage, const DistortionSummary& d, std::optional<double> budget);

/// Builds the output mesh: same positions, normals, faces and order as `input`; one texcoord per
/// wedge, normalised by the output page sizes; one material per output page named `page_<i>`
/// (copying the first input material's extra lines) with map_Kd `<stem>_page<i>.<ext>`; untextured
/// faces keep their input material.
TexturedMesh make_output_mesh(const TexturedMesh& input, const Atlas& atlas, const Layout& layout,
                              const std::string& stem, const std::string& image_ext,
                              const std::string& output_dir);

}  // namespace texdefrag
