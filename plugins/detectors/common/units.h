// Units of region growing (faces, input charts, or sub-patches) with their plane moments and the
// weighted adjacency graph between them.
#pragma once

#include "common/planarity.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"

#include <vector>

namespace texdefrag::detectors {

/// A partition of the textured faces into units and the graph of units sharing mesh edges.
struct UnitGraph {
  std::vector<int> face_unit;            ///< unit per face, -1 for untextured faces
  int num_units = 0;
  std::vector<PlaneMoments> moments;     ///< per unit
  std::vector<PlaneFit> fits;            ///< per unit
  std::vector<int> adj_offset;           ///< CSR: neighbours of u are adj[adj_offset[u] .. adj_offset[u+1])
  std::vector<int> adj;                  ///< neighbour unit ids (each neighbour once)
  std::vector<double> adj_length;        ///< 3D length of the edges shared with that neighbour (units)

  /// Number of neighbours of unit u.
  int degree(int u) const { return adj_offset[static_cast<size_t>(u) + 1] - adj_offset[static_cast<size_t>(u)]; }
};

/// Centre of the bounding box of the positions used by faces (the moments' reference point).
Vec3 reference_point(const TexturedMesh& mesh);

/// Builds the unit graph. Two units are adjacent when some welded edge (manifold or not) has faces
/// of both; the weight is the summed 3D length of such edges.
/// mesh, topo: the input and its topology; face_unit: unit per face in [0, num_units) or -1
/// (size = faces); num_units: number of units (every unit should own a face); ref: reference point.
UnitGraph build_unit_graph(const TexturedMesh& mesh, const Topology& topo, std::vector<int> face_unit,
                           int num_units, const Vec3& ref);

/// Unit per face where every textured face is its own unit (face-based growing). Returns the count.
int faces_as_units(const TexturedMesh& mesh, std::vector<int>& face_unit);

}  // namespace texdefrag::detectors
