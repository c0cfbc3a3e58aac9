// What every detector shares after it has labelled its units: region numbering, report statistics,
// and the optional outputs (label file, region-coloured model).
#pragma once

#include "texdefrag/stage/stage.h"

#include <array>
#include <string>
#include <vector>

namespace texdefrag::detectors {

/// The options every detector declares: "write_labels" and "write_colored" (paths, empty = off).
std::vector<OptionSpec> output_options();

/// Checks the output options' names before any run (from each detector's set_options): write_colored
/// must name an .obj file, since its MTL (<stem>.mtl) and palette (<stem>_palette.png) are written
/// beside it and would otherwise take its own name. Throws StageError naming `who` and the option.
void check_region_output_options(const std::string& who, const Options& options);

/// Regions from arbitrary per-face labels: faces with equal labels >= 0 share a region; regions are
/// numbered by decreasing face count (ties: first face first), so region 0 is the largest.
/// face_label: one label per face, negative = no region (must be untextured faces).
Regions regions_from_labels(const std::vector<int>& face_label);

/// Writes region statistics into `report`: textured_faces, faces_per_region {min, median, mean, max},
/// largest_region_fraction (faces). The region count is the framework's figure (`regions`).
void report_region_stats(const Regions& regions, json& report);

/// Writes the outputs requested by `options` (write_labels / write_colored) for ctx.regions, each
/// under its name in the output folder through ctx.output_path (write_colored also claims
/// <stem>.mtl and <stem>_palette.png beside it).
/// who: stage name for error messages; records written names in *ctx.report.
void write_region_outputs(const std::string& who, const Options& options, const StageContext& ctx);

/// A distinct, deterministic RGB colour per region id (golden-ratio hue walk); grey for -1.
std::array<uint8_t, 3> region_colour(int region);

/// Writes a region-coloured copy of `mesh`: OBJ + MTL at `obj_path` and a palette PNG beside it
/// (<stem>_palette.png), with every face mapped to the centre of its region's 4x4-texel palette
/// cell (so texture filtering cannot mix neighbouring colours). Geometry, normals and groups are
/// kept; untextured faces are grey. Throws StageError prefixed with `who` on write failure.
void write_colored_model(const std::string& who, const std::string& obj_path, const TexturedMesh& mesh,
                         const Regions& regions);

}  // namespace texdefrag::detectors
