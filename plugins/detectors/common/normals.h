// Noise-robust face normals for planar region growing on photogrammetric meshes.
//
// Bilateral normal filtering after Zheng, Fu, Au, Tai 2011, "Bilateral Normal Filtering for Mesh
// Denoising" (IEEE TVCG 17(10)): each face normal is replaced by the area- and similarity-weighted
// mean of its own and its edge-neighbours' normals, repeated a few times. The similarity (range)
// weight keeps creases (a wall and a roof at 90 degrees hardly influence each other) while the
// per-triangle noise of ContextCapture meshes (median 30-38 degrees between neighbouring faces on
// the development tiles) is averaged out. Only the normals are filtered; positions are untouched.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"

#include <vector>

namespace texdefrag::detectors {

/// Bilaterally filtered unit face normals.
/// mesh, topo: the model and its welded topology; faces sharing an edge (manifold or not) are
/// neighbours; untextured faces take part like textured ones.
/// iterations: >= 0 filter passes (0 returns the raw unit normals).
/// sigma: radians in (0, pi], width of the range weight exp(-chord^2 / (2 chord(sigma)^2)) where
/// chord = |n_i - n_j| = 2 sin(angle/2).
/// Returns one vector per face: unit length, or zero for faces without area.
std::vector<Vec3> filter_face_normals(const TexturedMesh& mesh, const Topology& topo, int iterations, double sigma);

/// Mean 3D length of the welded edges used by textured faces (model units); 0 when there are none.
double mean_edge_length(const TexturedMesh& mesh, const Topology& topo);

}  // namespace texdefrag::detectors
