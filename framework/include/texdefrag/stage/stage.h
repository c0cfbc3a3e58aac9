// Stage interfaces: detectors partition faces into regions, mergers change the atlas's charts and
// UVs, packers place charts on pages. One static StageInfo per stage (PDAL style): its qualified
// name `kind.name` is the registry key, the JSON "type", the error prefix and the report node.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/stage/options.h"

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace texdefrag {

class OutputSet;

/// Progress callback: (stage name, fraction in [0,1]). Return false to cancel. Called from the
/// thread running the stage; the framework rate-limits it to changes.
using ProgressFn = std::function<bool(const std::string& stage, double fraction)>;

/// Thrown when a stage cannot run on its input (bad labels file, mesh the stage cannot handle...).
/// The message names the stage and the cause. The pipeline turns it into exit code 1.
struct StageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
/// Thrown by the progress wrapper when the user cancels.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

/// A partition of the faces into regions: merges only happen between charts of the same region.
struct Regions {
  std::vector<int> face_region;  ///< region per face, -1 for faces outside any region (untextured)
  int num_regions = 0;
  /// The Comprehensive Planarity Index weights (flatness, compactness, normal: Liu et al.'s w1, w2,
  /// w3) the detector used, when it uses the CPI. Mergers that rank charts by planarity take these,
  /// so the weights are declared once, by the detector's options.
  std::optional<std::array<double, 3>> planarity_weights;
};

/// Placement of the atlas on output pages, produced by a packer.
struct Layout {
  struct PageSize { int width = 0, height = 0; };
  std::vector<PageSize> pages;      ///< output pages
  std::vector<int> chart_page;      ///< output page per chart
  std::vector<Vec2> wedge_uv;       ///< final per-wedge position in texels of its output page (y up)
};

/// Everything a stage sees. Stages read what precedes them and write only their own product.
struct StageContext {
  const TexturedMesh* mesh = nullptr;   ///< the input, never modified
  const Topology* topology = nullptr;
  const ChartSet* input_charts = nullptr;  ///< charts of the input UVs
  Regions regions;                      ///< written by the detector
  Atlas atlas;                          ///< starts as input_charts->atlas; mergers change it
  Layout layout;                        ///< written by the packer
  json* report = nullptr;               ///< this stage's node of the run report
  ProgressFn progress;                  ///< never null inside a stage (framework supplies a no-op)
  std::string input_path;               ///< the input OBJ path (for sidecar files), may be empty
  /// The run's write service; null when the run writes nothing (--no-write, tests). Stages never
  /// open files themselves: they ask output_path() for every side output.
  OutputSet* outputs = nullptr;

  /// Reports progress; throws Cancelled when the callback asks to stop.
  void step(const std::string& stage, double fraction) const;
  /// Where stage `stage` writes its side output `name` (a plain relative name under the output
  /// folder, e.g. "regions.obj"); the file appears with the run's other outputs when the run
  /// succeeds. Throws StageError naming the stage and the file when the run writes no output or
  /// the write service refuses the name (absolute, '..', an input file...).
  std::string output_path(const std::string& stage, const std::string& name) const;
};

struct StageInfo;

class Stage {
 public:
  virtual ~Stage() = default;
  /// Called once with validated options before any run.
  virtual void set_options(const Options& options) { options_ = options; }
  const Options& options() const { return options_; }

 protected:
  Options options_;
};

class Detector : public Stage {
 public:
  /// Fills ctx.regions. Must assign every textured face a region in [0, num_regions).
  virtual void detect(StageContext& ctx) = 0;
};

class Merger : public Stage {
 public:
  /// Changes ctx.atlas (charts, wedges, UVs). Must keep every face and leave no flipped or
  /// overlapping triangles that were not in the input; must call atlas.compact() at the end.
  virtual void merge(StageContext& ctx) = 0;
  /// The area-weighted ARAP distortion (core/distortion.h) the merger promises to stay within, from
  /// its options; none by default. The pipeline checks it after merge() (check_merger_distortion).
  virtual std::optional<double> distortion_budget() const { return std::nullopt; }
};

class Packer : public Stage {
 public:
  /// Fills ctx.layout from ctx.atlas. Charts must not overlap (gutter kept between them).
  virtual void pack(StageContext& ctx) = 0;
};

enum class StageKind { Detector, Merger, Packer };
const char* to_string(StageKind k);

struct StageInfo {
  std::string name;         ///< qualified, `detectors.region_growing`
  StageKind kind = StageKind::Detector;
  std::string description;  ///< one line
  std::string doc;          ///< doc page path relative to the repository root
  std::vector<OptionSpec> options;
  std::function<std::unique_ptr<Stage>()> create;
};

}  // namespace texdefrag

namespace texdefrag {

/// Validated options of `info` from a JSON object (its key "type", if any, is skipped). Unknown
/// keys (with the nearest valid one suggested), wrong types and out-of-range values are appended
/// to `errors` as "WHERE: 'KEY' message"; declared defaults fill the missing keys.
Options make_options(const StageInfo& info, const json& values, const std::string& where,
                     std::vector<std::string>& errors);

/// Declared defaults with `overrides` applied; throws std::invalid_argument listing the errors.
/// Convenient in tests: default_options(S::info(), {{"angle_threshold_deg", 30}}).
Options default_options(const StageInfo& info, const json& overrides = json::object());

}  // namespace texdefrag
