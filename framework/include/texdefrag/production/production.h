// A production is one input: a folder of model tiles (a ContextCapture OSGB pyramid with its
// metadata.xml, or a folder of OBJ tiles) processed tile by tile with one configuration into the
// same layout under the output folder (docs/production.md).
//
// Layout rules:
// - kind "contextcapture": the folder holds metadata.xml; every .osgb file under it (any depth:
//   `Tile_*/` or `Data/Tile_*/`) is a task; every other file (metadata.xml, ...) is copied.
// - kind "obj_folder": a folder without metadata.xml holding .obj files (any depth); each is a
//   task; files other than OBJ, MTL and images (jpg, jpeg, png, tif, tiff, bmp, tga) are copied.
// - a tileset.json (3D Tiles) production is run by io/tiles3d.h (run_tileset, plan_tileset): the
//   CLI sends a folder holding one there; here a folder with only a tileset.json is an error
//   saying so.
// A task's output goes to OUT/<its relative folder>/ with the input's file stem, and its run report
// beside it (<stem>.report.json, unless output.write_report is false); OUT/texdefrag_summary.json
// lists every task with its figures, and totals per level.
#pragma once

#include "texdefrag/pipeline/pipeline.h"

#include <string>
#include <vector>

namespace texdefrag {

struct ProductionTask {
  std::string input;       ///< the tile file (absolute or as given under the production folder)
  std::string relative;    ///< its path relative to the production folder ("Tile_+000_+015/x.osgb")
  std::string output_dir;  ///< OUT/<relative folder>
  std::string stem;        ///< output stem (the input file's stem)
  std::string level;       ///< "L16" from a ContextCapture name (`_L16_`), "root" for a tile root, "" otherwise
};

struct Production {
  std::string kind;  ///< "contextcapture" or "obj_folder"
  std::string root;  ///< the production folder as given
  std::vector<ProductionTask> tasks;  ///< sorted by relative path
  std::vector<std::string> copies;    ///< relative paths of files copied unchanged
};

/// True when `input` is a folder (a production); false for a model file.
bool is_production(const std::string& input);

/// Lists a production's tasks and copies. output_dir may be empty (tasks' output_dir then empty).
/// Throws FormatError naming the folder when it holds no tile, or only a tileset.json.
Production list_production(const std::string& input, const std::string& output_dir);

/// The tasks as JSON ({"kind", "root", "tasks": [{input, relative, output_dir, stem, level}],
/// "copies": [...]}), for batch runners.
json production_json(const Production& p);

struct ProductionRunOptions {
  std::string output_dir;               ///< must not be the production folder or inside it
  ProgressFn progress;                  ///< forwarded to each tile's run; may be empty
  bool allow_missing_children = false;  ///< see RunOptions
  /// Called after each task with its index, task, summary row (status "ok" or "failed" with its
  /// error) and run report (null when the tile was copied or failed), e.g. to print a line; may be empty.
  std::function<void(size_t, const ProductionTask&, const json& row, const json& report)> on_task;
};

/// Runs every task in order with `config` (a tile with no textured face is copied unchanged),
/// copies the other files, and writes OUT/texdefrag_summary.json. A failing task (unreadable tile,
/// missing PagedLOD child, a stage's error) leaves none of its files (its OutputSet is not
/// committed) and is recorded in the summary with status "failed" and its error
/// ("production task I/N (RELATIVE): <error naming the file>", then " (a child of P)" naming the
/// .osgb files beside an OSGB tile that name it as a child, io/osgb.h osgb_parents); the other
/// tasks go on. The summary's "failed" counts them. A ConfigError (the configuration itself) is rethrown at once.
/// Returns the summary.
json run_production(const PipelineConfig& config, const Production& production, const ProductionRunOptions& options);

}  // namespace texdefrag
