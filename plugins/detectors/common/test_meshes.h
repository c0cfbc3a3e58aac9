// Hand-built meshes with ground-truth planes for the detector tests and benchmark: the cases of
// the paper's Figure 3 (jagged borders, elongated strips, small smoothly curved components) and a
// chart wrapping a building corner. Charts ("patches") are explicit: every chart gets its own
// duplicated positions and UV island, as photogrammetry exports have.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/output_set.h"
#include "texdefrag/stage/stage.h"

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace texdefrag::detectors::testmesh {

/// A test mesh and its truth: truth[f] = ground-truth plane (or component) id of face f.
struct Case {
  std::string name;
  TexturedMesh mesh;
  std::vector<int> truth;
};

/// Accumulates triangles with a chart id and a truth id, then builds the mesh.
class Builder {
 public:
  /// noise: displacement of each point as a function of its exact (undisplaced) position, so points
  /// shared by two grids move identically; empty = none.
  explicit Builder(std::function<Vec3(const Vec3&)> noise = {}) : noise_(std::move(noise)) {}
  /// Adds one triangle. chart: chart id >= 0 (any numbering); truth: truth id.
  void add(const Vec3& a, const Vec3& b, const Vec3& c, int chart, int truth);
  /// Adds a grid of nu x nv quads (2 triangles each) spanning origin + i*U/nu + j*V/nv; quads are
  /// grouped into charts of pu x pv quads numbered from chart_base. Returns the next free chart id.
  int add_grid(const Vec3& origin, const Vec3& U, const Vec3& V, int nu, int nv, int pu, int pv, int chart_base,
               int truth);
  /// Builds the mesh: one 1024^2 page (image file not created), each chart's UVs a planar projection
  /// into its own cell of the page.
  Case build(const std::string& name) const;
  size_t size() const { return tris_.size(); }

 private:
  std::function<Vec3(const Vec3&)> noise_;
  std::vector<std::array<Vec3, 3>> tris_;
  std::vector<int> chart_, truth_;
};

/// Deterministic isotropic noise in [-amplitude, amplitude]^3 from a hash of the position.
std::function<Vec3(const Vec3&)> hash_noise(double amplitude, unsigned seed = 1);

/// Figure 3a: a wall and a roof meeting at a right angle, vertex noise (normals vary by ~20 deg
/// between neighbouring faces). Truth: wall 0, roof 1.
Case jagged_case();
/// Figure 3b: a facade with a V-shaped ledge (two tilted 1-quad rows, strip-shaped charts) that does
/// not span the whole width. Truth: everything is the facade (0): the ledge is a facade detail.
Case strip_case();
/// Figure 3c: ground, two facades joined by a rounded corner (quarter cylinder of radius 6, 12
/// segments) and a free-standing half-cylinder column (radius 1, 24 segments).
/// Truth: facade A 0, facade B 1, corner 2, ground 3, column 4.
Case curved_case();
/// A wall and a roof where a row of charts wraps the crease (half of each such chart on the wall,
/// half on the roof). Truth: wall 0, roof 1.
Case corner_chart_case();
/// A noisy box-shaped building (4 facades, flat roof, ground) with about `faces` triangles in charts
/// of 2x2 quads; for benchmarks. Truth: one id per side.
Case building_case(int faces);

/// A detection and its report node.
struct Detection {
  Regions regions;
  json report = json::object();
};

/// Creates detector `name` through the registry (loading the plugins), sets its declared defaults
/// with `overrides` applied, builds topology and charts of `mesh` and runs detect().
/// progress: optional callback given to the stage. outputs: the write service for side outputs
/// (write_labels, write_colored), or null. Throws what the stage throws.
Detection run_detector(const std::string& name, const TexturedMesh& mesh, const json& overrides = json::object(),
                       ProgressFn progress = {}, OutputSet* outputs = nullptr);

}  // namespace texdefrag::detectors::testmesh
