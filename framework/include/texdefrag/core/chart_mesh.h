// A halfedge (OpenMesh) view of one chart, for plugins that want circulators and boundary loops.
//
// note: the framework's own structures are flat tables (core/topology.h explains why: real input
// is not manifold). A chart, though, is nearly always a manifold patch in UV space, which is where
// OpenMesh's halfedge structure fits: vertices are the chart's wedges (so the mesh is the chart as
// cut along its seams, with UVs as positions) and faces are its triangles. Faces OpenMesh refuses
// (complex edge or vertex, degenerate) are listed, never dropped silently.
#pragma once

#include "texdefrag/core/charts.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <vector>

namespace texdefrag {

struct ChartMeshTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;  // (u, v, 0) in texels
};
using ChartTriMesh = OpenMesh::TriMesh_ArrayKernelT<ChartMeshTraits>;

struct ChartMesh {
  ChartTriMesh mesh;
  std::vector<int> face_of;      ///< OpenMesh face index -> mesh face id
  std::vector<int> wedge_of;     ///< OpenMesh vertex index -> atlas wedge id
  std::vector<int> refused;      ///< mesh face ids OpenMesh could not add (non-manifold, degenerate)
};

/// Builds the halfedge view of chart `chart` of `atlas`: one vertex per wedge at (u, v, 0) texels,
/// one face per triangle in face order, oriented as in the input (counter-clockwise UV triangles
/// keep their orientation). O(faces of the chart).
/// @param atlas  any atlas state; `chart` in [0, atlas.num_charts)
ChartMesh chart_mesh(const Atlas& atlas, int chart);

/// Number of boundary loops of a chart mesh (1 for a disk, 0 for a closed chart, more with holes).
int boundary_loops(const ChartTriMesh& mesh);

}  // namespace texdefrag
