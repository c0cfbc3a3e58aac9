// Test support for the packers: meshes whose charts are given UV polygons, running a packer by
// name, and the layout invariants every packer must keep (checked independently of the packers'
// own footprint code where it matters: overlap is checked on the final UVs).
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/stage/stage.h"

#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace texdefrag::packtest {

/// A mesh with one page of page_size^2 texels whose charts are the given polygons.
/// polys: each a counter-clockwise polygon in texels, fan-triangulated from its first vertex
/// (convex or star-shaped from vertex 0); each polygon gets its own 3D vertices (flat, z = index),
/// so each is one chart. page_size: > 0 texels.
TexturedMesh polygon_mesh(const std::vector<std::vector<Vec2>>& polys, int page_size);

/// Random charts: axis-aligned and rotated rectangles, triangles and L-free convex polygons with
/// sides in [min_side, max_side] texels, at random places of a page of page_size texels.
std::vector<std::vector<Vec2>> random_polygons(std::mt19937& rng, int count, double min_side, double max_side,
                                               int page_size);

/// "Building-like" charts: mostly axis-aligned rectangles (facades, roofs) of varied size plus a
/// share of small triangles/quads, in texels, whole-texel corners.
std::vector<std::vector<Vec2>> building_polygons(std::mt19937& rng, int count, int page_size);

/// A mesh, its topology and charts, and a packer run on them.
struct PackRun {
  TexturedMesh mesh;
  Topology topo;
  ChartSet charts;
  StageContext ctx;
  json report = json::object();
};

/// Builds topology and charts of `mesh` and runs packer `name` with `options` (defaults filled in).
/// `edit`, when set, changes the working atlas before packing (to simulate a merger's output).
/// `progress`, when set, is the stage's progress callback (else a no-op that never cancels).
/// Loads the plugins on first use. Exceptions of the packer propagate.
std::unique_ptr<PackRun> run_packer(const std::string& name, TexturedMesh mesh,
                                    const json& options = json::object(),
                                    const std::function<void(Atlas&)>& edit = nullptr,
                                    const ProgressFn& progress = nullptr);

/// The invariant suite every packer must pass, run by each packer's test executable:
/// random charts (valid layout, exact whole-texel placement), several gutters, multiple pages
/// under a small max_page_size, page rounding (multiple and power of two), the too-large-chart
/// error, the efficiency in the report, and the freely rotated merged chart (rigid, in page).
void packer_invariant_suite(const std::string& name);

/// Real tiles (texdefrag::testing::real_models(max_faces)): input charts packed with valid
/// layout, every chart exact; returns (model file name, efficiency) per model.
std::vector<std::pair<std::string, double>> packer_real_suite(const std::string& name, size_t max_faces);

/// Checks (with gtest EXPECT) the invariants: every chart on a valid page; every used wedge inside
/// its page; every chart's output UVs a rigid motion of its atlas UVs; no two charts closer than
/// `gutter` cells (conservative rasterisation of the final triangles on each page's texel grid).
void expect_valid_layout(const PackRun& run, int gutter);

/// Packing efficiency computed from the layout: sum of |UV area| of the faces / sum of page areas.
double layout_efficiency(const PackRun& run);

/// Fraction of charts whose output UVs equal the input UVs turned by a multiple of 90 degrees and
/// moved by an integer vector (exactly, within 1e-9 texels).
double exact_chart_fraction(const PackRun& run);

}  // namespace texdefrag::packtest
