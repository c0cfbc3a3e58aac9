// Cutting a tile into one model per building plus a remainder (issue 14): the building-level data
// Liu et al. 2024 measured on (187 single buildings), made from real urban tiles.
//
// A building is a connected set of faces that detectors.semantic classes as `building` (its walls
// and roofs; merged by connectivity) with at least `min_faces` faces; every other face (ground,
// vegetation, other, small building pieces, untextured faces) goes to the remainder. Contract:
// every input face is in exactly one output model, with its positions, texture coordinates,
// normals, material and group exactly as read (sub-meshes only re-index); pages are shared.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/stage/options.h"

#include <string>
#include <vector>

namespace texdefrag::buildings {

struct ExtractOptions {
  int min_faces = 200;                  ///< smaller building components go to the remainder (>= 1)
  json detector = json::object();       ///< options of detectors.semantic (defaults when empty)
};

struct Part {
  std::string name;                     ///< "building_<k>" (k by decreasing size) or "rest"
  std::vector<size_t> faces;            ///< input face indices, increasing
};

struct Extraction {
  std::vector<Part> parts;              ///< buildings first (largest first), then "rest" (may be empty)
  json detector_report;                 ///< detectors.semantic's report node
};

/// Classifies the faces (detectors.semantic, loaded through the registry) and splits them.
/// Throws StageError/ConfigError (bad detector options) naming the key.
Extraction extract_buildings(const TexturedMesh& mesh, const ExtractOptions& options);

/// The faces `faces` of `mesh` as a model of their own: only used positions, texture coordinates
/// and normals, in first-use order; all materials, pages and groups kept (indices unchanged).
TexturedMesh sub_mesh(const TexturedMesh& mesh, const std::vector<size_t>& faces);

/// Writes every part as OUT/<stem>_<part>.obj + .mtl, the used page images copied once into OUT,
/// and OUT/<stem>_buildings.json (parts, faces, the detector report). Then reads every written
/// OBJ back and checks that each input face appears exactly once with bit-identical corners
/// (positions and texture coordinates); throws std::runtime_error naming the face otherwise.
/// out_dir: created if missing; must not be the input's folder; input files are never written.
json write_parts(const TexturedMesh& mesh, const std::string& input_path, const Extraction& ex,
                 const std::string& out_dir);

}  // namespace texdefrag::buildings
