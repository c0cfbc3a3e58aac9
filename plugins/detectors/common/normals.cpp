// Bilateral normal filtering, after Zheng et al. 2011 (see normals.h).
#include "common/normals.h"

#include <cmath>

namespace texdefrag::detectors {

std::vector<Vec3> filter_face_normals(const TexturedMesh& mesh, const Topology& topo, int iterations, double sigma) {
  const size_t nf = mesh.faces.size();
  std::vector<Vec3> n(nf, Vec3::Zero());
  std::vector<double> area(nf, 0);
  for (size_t f = 0; f < nf; ++f) {
    area[f] = face_area_3d(mesh, f);
    const Vec3 v = face_normal(mesh, f);
    if (area[f] > 0 && v.norm() > 0 && v.allFinite()) n[f] = v.normalized();
    else area[f] = 0;
  }
  if (iterations <= 0) return n;
  const double chord = 2 * std::sin(0.5 * sigma);
  const double inv2s2 = 1.0 / (2 * chord * chord);
  std::vector<Vec3> next(nf);
  for (int it = 0; it < iterations; ++it) {
    for (size_t f = 0; f < nf; ++f) {
      if (!(area[f] > 0)) {
        next[f] = n[f];
        continue;
      }
      Vec3 sum = area[f] * n[f];
      for (int k = 0; k < 3; ++k) {
        const Edge& e = topo.edges[static_cast<size_t>(topo.face_edge[f][static_cast<size_t>(k)])];
        for (int i = 0; i < e.num_faces; ++i) {
          const size_t g = static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face);
          if (g == f || !(area[g] > 0)) continue;
          sum += area[g] * std::exp(-(n[f] - n[g]).squaredNorm() * inv2s2) * n[g];
        }
      }
      const double len = sum.norm();
      next[f] = len > 0 ? Vec3(sum / len) : n[f];
    }
    n.swap(next);
  }
  return n;
}

double mean_edge_length(const TexturedMesh& mesh, const Topology& topo) {
  double sum = 0;
  size_t count = 0;
  for (const Edge& e : topo.edges) {
    bool textured = false;
    for (int i = 0; i < e.num_faces; ++i)
      textured |= mesh.faces[static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face)].page != kNoPage;
    if (!textured) continue;
    sum += (mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.a)])] -
            mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
    ++count;
  }
  return count > 0 ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace texdefrag::detectors
