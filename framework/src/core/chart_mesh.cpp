// note: GCC 12 reports a false -Wmaybe-uninitialized inside OpenMesh's property vectors
// (VectorT's default constructor leaves its storage uninitialised on purpose) when they are
// inlined here; it is not about our code.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "texdefrag/core/chart_mesh.h"

#include <OpenMesh/Core/System/omstream.hh>

#include <unordered_map>

namespace texdefrag {

ChartMesh chart_mesh(const Atlas& atlas, int chart) {
  ChartMesh cm;
  // note: OpenMesh logs "complex edge" for each refused face; refusals are returned instead.
  const bool was_enabled = omerr().is_enabled();
  omerr().disable();
  std::unordered_map<int, ChartTriMesh::VertexHandle> vertex_of_wedge;
  for (size_t f = 0; f < atlas.face_chart.size(); ++f) {
    if (atlas.face_chart[f] != chart) continue;
    std::vector<ChartTriMesh::VertexHandle> vh;
    for (int w : atlas.face_wedge[f]) {
      auto it = vertex_of_wedge.find(w);
      if (it == vertex_of_wedge.end()) {
        const Vec2& p = atlas.wedge_uv[static_cast<size_t>(w)];
        it = vertex_of_wedge.emplace(w, cm.mesh.add_vertex(ChartTriMesh::Point(p.x(), p.y(), 0))).first;
        cm.wedge_of.push_back(w);
      }
      vh.push_back(it->second);
    }
    const auto fh = (vh[0] == vh[1] || vh[1] == vh[2] || vh[0] == vh[2]) ? ChartTriMesh::FaceHandle()
                                                                        : cm.mesh.add_face(vh);
    if (!fh.is_valid()) {
      cm.refused.push_back(static_cast<int>(f));
      continue;
    }
    cm.face_of.push_back(static_cast<int>(f));
  }
  if (was_enabled) omerr().enable();
  return cm;
}

int boundary_loops(const ChartTriMesh& mesh) {
  std::vector<char> seen(mesh.n_halfedges(), 0);
  int loops = 0;
  for (auto h : mesh.halfedges()) {
    if (!mesh.is_boundary(h) || seen[static_cast<size_t>(h.idx())]) continue;
    ++loops;
    auto c = h;
    do {
      seen[static_cast<size_t>(c.idx())] = 1;
      c = mesh.next_halfedge_handle(c);
    } while (c != h && !seen[static_cast<size_t>(c.idx())]);
  }
  return loops;
}

}  // namespace texdefrag
