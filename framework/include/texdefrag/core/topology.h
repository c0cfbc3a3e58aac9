// 3D topology of a TexturedMesh: positions welded by exact equality, and edge-face incidence.
//
// note: OpenMesh's halfedge structure cannot hold what real photogrammetry files contain (edges
// shared by three or more faces, faces with inconsistent orientation, repeated faces); its
// add_face refuses them, which would mean dropping faces. We keep a flat edge->faces incidence
// table instead, which represents any triangle soup, and report every defect. Stages that need a
// manifold view (chart parameterisation) only ever walk edges with exactly two incident faces.
#pragma once

#include "texdefrag/core/mesh.h"

#include <array>
#include <vector>

namespace texdefrag {

/// Defects found while building topology. Nothing is removed: faces stay, counts are reported.
struct TopologyReport {
  size_t welded_vertices = 0;       ///< V3: distinct 3D positions referenced by faces
  size_t edges = 0;                 ///< distinct undirected welded edges
  size_t boundary_edges = 0;        ///< edges with one face
  size_t non_manifold_edges = 0;    ///< edges with three or more faces
  size_t degenerate_faces = 0;      ///< faces with two or three equal welded vertices
  size_t zero_area_faces = 0;       ///< non-degenerate faces whose 3D area is 0
  size_t duplicate_faces = 0;       ///< faces whose welded vertex set repeats an earlier face's
  size_t non_manifold_vertices = 0; ///< vertices whose face fan is not one edge-connected sheet
};

/// An undirected edge of the welded mesh and the faces that contain it.
struct Edge {
  int a = 0, b = 0;        ///< welded vertex ids, a < b
  int first_incidence = 0; ///< offset into Topology::edge_faces
  int num_faces = 0;       ///< number of incident faces (1 boundary, 2 manifold, >2 non-manifold)
};

/// Incidence of one face on one edge: which face and which local edge (k: corners k, k+1 mod 3).
struct EdgeIncidence {
  int face = 0;
  int local = 0;
};

struct Topology {
  std::vector<int> vertex_of_position;        ///< position index -> welded vertex id (-1 if unused)
  std::vector<int> position_of_vertex;        ///< welded vertex id -> first position index
  std::vector<std::array<int, 3>> face_vertex;///< welded vertex ids per face corner
  std::vector<std::array<int, 3>> face_edge;  ///< edge ids per face; local edge k joins corners k,k+1
  std::vector<Edge> edges;
  std::vector<EdgeIncidence> edge_faces;      ///< grouped by edge, see Edge::first_incidence
  std::vector<uint8_t> face_degenerate;       ///< 1 when two corners share a welded vertex
  TopologyReport report;

  size_t num_vertices() const { return position_of_vertex.size(); }

  /// The face across local edge k of face f, or -1 when that edge is a boundary or non-manifold.
  int opposite_face(int f, int k) const;
  /// For face f, local edge k, the incidence record of the other face when the edge is manifold.
  const EdgeIncidence* opposite(int f, int k) const;
};

/// Builds topology. Welds positions that are bit-identical (the exports this tool targets repeat the
/// exact same coordinates at seams). Cost: O(F log F). Never fails; defects go into the report.
Topology build_topology(const TexturedMesh& mesh);

/// 3D area of face f (0 for degenerate faces).
double face_area_3d(const TexturedMesh& mesh, size_t f);
/// Unit normal of face f (zero vector when the face has zero area).
Vec3 face_normal(const TexturedMesh& mesh, size_t f);

}  // namespace texdefrag
