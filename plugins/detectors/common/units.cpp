#include "common/units.h"

#include <algorithm>
#include <limits>
#include <tuple>

namespace texdefrag::detectors {

Vec3 reference_point(const TexturedMesh& mesh) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (const Face& f : mesh.faces)
    for (int v : f.v) {
      if (v < 0 || static_cast<size_t>(v) >= mesh.positions.size()) continue;
      lo = lo.cwiseMin(mesh.positions[static_cast<size_t>(v)]);
      hi = hi.cwiseMax(mesh.positions[static_cast<size_t>(v)]);
    }
  if (!(lo.x() <= hi.x())) return Vec3::Zero();
  return 0.5 * (lo + hi);
}

UnitGraph build_unit_graph(const TexturedMesh& mesh, const Topology& topo, std::vector<int> face_unit,
                           int num_units, const Vec3& ref) {
  UnitGraph g;
  g.face_unit = std::move(face_unit);
  g.num_units = num_units;
  const size_t nu = static_cast<size_t>(num_units);
  g.moments.assign(nu, PlaneMoments{});
  for (size_t f = 0; f < g.face_unit.size(); ++f) {
    const int u = g.face_unit[f];
    if (u >= 0) g.moments[static_cast<size_t>(u)].add(face_moments(mesh, f, ref));
  }
  g.fits.resize(nu);
  for (size_t u = 0; u < nu; ++u) g.fits[u] = fit_plane(g.moments[u]);

  // Edge-shared pairs, both directions, then sorted and summed into CSR.
  std::vector<std::tuple<int, int, double>> pairs;
  pairs.reserve(topo.edges.size() * 2);
  for (const Edge& e : topo.edges) {
    if (e.num_faces < 2 || e.a == e.b) continue;
    const double len = (mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.a)])] -
                        mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
    for (int i = 0; i < e.num_faces; ++i)
      for (int j = i + 1; j < e.num_faces; ++j) {
        const int ua = g.face_unit[static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face)];
        const int ub = g.face_unit[static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + j)].face)];
        if (ua < 0 || ub < 0 || ua == ub) continue;
        pairs.emplace_back(ua, ub, len);
        pairs.emplace_back(ub, ua, len);
      }
  }
  std::sort(pairs.begin(), pairs.end());
  g.adj_offset.assign(nu + 1, 0);
  for (size_t i = 0; i < pairs.size();) {
    size_t j = i;
    double len = 0;
    while (j < pairs.size() && std::get<0>(pairs[j]) == std::get<0>(pairs[i]) &&
           std::get<1>(pairs[j]) == std::get<1>(pairs[i]))
      len += std::get<2>(pairs[j++]);
    g.adj.push_back(std::get<1>(pairs[i]));
    g.adj_length.push_back(len);
    ++g.adj_offset[static_cast<size_t>(std::get<0>(pairs[i])) + 1];
    i = j;
  }
  for (size_t u = 0; u < nu; ++u) g.adj_offset[u + 1] += g.adj_offset[u];
  return g;
}

int faces_as_units(const TexturedMesh& mesh, std::vector<int>& face_unit) {
  face_unit.assign(mesh.faces.size(), -1);
  int n = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    if (mesh.faces[f].page != kNoPage) face_unit[f] = n++;
  return n;
}

}  // namespace texdefrag::detectors
