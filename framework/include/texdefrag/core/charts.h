// Charts, seams and the working atlas.
//
// Definitions (../shared/docs/METHOD.md, issue 2 section 5):
// - An edge shared by faces f and g is UV-continuous when both of its welded endpoints carry the
//   same (u, v, page) on both sides. Continuity is tested on manifold and non-manifold edges alike
//   (pairwise), so chart counts follow the definition on any input.
// - Chart = connected component of textured faces over UV-continuous edges.
// - Seam edge = edge with exactly two incident textured faces that is not UV-continuous. Seam
//   edges between the same two charts form one SeamChain (possibly several polylines; a chain is a
//   "move" of the mergers). Non-manifold edges are never seams: no merge may cross them.
// - Wedge = a group of corners at one welded vertex joined across UV-continuous edges; all corners
//   of a wedge have the same UV. Wedges are the unknowns of UV optimisation.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"

#include <vector>

namespace texdefrag {

struct SeamChain {
  int chart_a = -1, chart_b = -1;  ///< chart_a <= chart_b (equal: a cut inside one chart)
  std::vector<int> edges;          ///< edge ids (Topology::edges), each a seam edge
  double length_3d = 0;            ///< sum of 3D edge lengths
};

/// Per-chart geometry, all in input units (texels of the chart's own page, metres in 3D).
struct ChartStats {
  int page = kNoPage;
  int faces = 0;
  double uv_area = 0;         ///< texels^2 (absolute, sum over faces)
  double area_3d = 0;         ///< model units^2
  double uv_border = 0;       ///< texels: every border edge of the chart (seams and mesh boundary)
  Vec3 centroid = Vec3::Zero(); ///< area-weighted 3D centroid
  Vec3 normal = Vec3::Zero();   ///< fitted plane normal (smallest covariance eigenvector), unit
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero(); ///< covariance eigenvalues s1<=s2<=s3
};

/// The working UV layout shared by mergers and packers. UVs are in texels of the face's input page.
struct Atlas {
  std::vector<Vec2> wedge_uv;                  ///< texels
  std::vector<int> wedge_vertex;               ///< welded vertex id of each wedge
  std::vector<std::array<int, 3>> face_wedge;  ///< wedge per face corner, -1 for untextured faces
  std::vector<int> face_chart;                 ///< chart per face, -1 for untextured faces
  std::vector<int> chart_page;                 ///< input page of each chart's texels
  int num_charts = 0;

  /// Renumbers charts 0..n-1 in order of first face and drops unused wedges. Returns the new count.
  int compact();
  /// Faces of every chart, in face order.
  std::vector<std::vector<int>> chart_faces() const;
};

struct ChartSet {
  Atlas atlas;                       ///< input UVs; one chart per UV-connected component
  std::vector<ChartStats> stats;     ///< per chart
  std::vector<SeamChain> chains;     ///< chart pairs sharing seam edges
  std::vector<std::vector<int>> chart_chains; ///< chain ids per chart (the chart adjacency graph)
  size_t zero_area_charts = 0;       ///< charts whose UV area is 0
  size_t seam_edges = 0;
  double seam_length_3d = 0;         ///< seam edges counted once, mesh boundary excluded
  double uv_border_length = 0;       ///< texels, sum of ChartStats::uv_border
};

/// True when local edge k of face f and local edge l of face g (same welded edge) are UV-continuous.
bool uv_continuous(const TexturedMesh& mesh, const Topology& topo, int f, int k, int g, int l);

/// Computes charts, wedges, seams, chains and per-chart statistics of the input UVs.
/// Requires page sizes known for every page used by a face. O(F log F).
ChartSet build_charts(const TexturedMesh& mesh, const Topology& topo);

/// Statistics of the charts of an atlas (any UV state): same meaning as ChartSet::stats, uv from
/// atlas.wedge_uv. Used by mergers after they change UVs.
std::vector<ChartStats> chart_stats(const TexturedMesh& mesh, const Topology& topo, const Atlas& atlas);

/// Signed UV area of face f in the atlas (texels^2, positive when counter-clockwise).
double atlas_face_area(const Atlas& atlas, int f);

}  // namespace texdefrag
