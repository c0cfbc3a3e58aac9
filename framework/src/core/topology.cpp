#include "texdefrag/core/topology.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <unordered_map>

namespace texdefrag {
namespace {

struct PosKey {
  uint64_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PosHash {
  size_t operator()(const PosKey& k) const {
    uint64_t h = k.x * 0x9E3779B97F4A7C15ULL;
    h ^= k.y + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    h ^= k.z + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};
uint64_t bits(double d) {
  if (d == 0.0) d = 0.0;  // note: +0 and -0 are the same position
  uint64_t u;
  std::memcpy(&u, &d, sizeof u);
  return u;
}

}  // namespace

int Topology::opposite_face(int f, int k) const {
  const EdgeIncidence* o = opposite(f, k);
  return o ? o->face : -1;
}

const EdgeIncidence* Topology::opposite(int f, int k) const {
  const Edge& e = edges[static_cast<size_t>(face_edge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
  if (e.num_faces != 2) return nullptr;
  const EdgeIncidence* inc = &edge_faces[static_cast<size_t>(e.first_incidence)];
  if (inc[0].face == f && inc[0].local == k) return &inc[1];
  return &inc[0];
}

namespace {

// Welds the positions faces reference, by exact coordinates, in order of first reference (stable
// ids): fills t.vertex_of_position, position_of_vertex, face_vertex, report.welded_vertices.
void weld_vertices(const TexturedMesh& mesh, Topology& t) {
  const size_t nf = mesh.faces.size();
  t.vertex_of_position.assign(mesh.positions.size(), -1);
  std::unordered_map<PosKey, int, PosHash> weld;
  weld.reserve(mesh.positions.size());
  t.face_vertex.resize(nf);
  for (size_t f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const int p = mesh.faces[f].v[static_cast<size_t>(k)];
      int& slot = t.vertex_of_position[static_cast<size_t>(p)];
      if (slot < 0) {
        const Vec3& x = mesh.positions[static_cast<size_t>(p)];
        auto it = weld.emplace(PosKey{bits(x.x()), bits(x.y()), bits(x.z())},
                               static_cast<int>(t.position_of_vertex.size()));
        if (it.second) t.position_of_vertex.push_back(p);
        slot = it.first->second;
      }
      t.face_vertex[f][static_cast<size_t>(k)] = slot;
    }
  }
  t.report.welded_vertices = t.position_of_vertex.size();
}

// One face side: welded vertex ids a <= b, the face and its local edge index.
struct Rec { int a, b, face, local; };

// Flags degenerate faces (t.face_degenerate, counts degenerate and zero-area faces) and returns
// the three side records of every face, sorted by (a, b, face, local).
std::vector<Rec> classify_faces_and_sides(const TexturedMesh& mesh, Topology& t) {
  const size_t nf = mesh.faces.size();
  t.face_degenerate.assign(nf, 0);
  std::vector<Rec> recs;
  recs.reserve(nf * 3);
  for (size_t f = 0; f < nf; ++f) {
    const auto& fv = t.face_vertex[f];
    if (fv[0] == fv[1] || fv[1] == fv[2] || fv[0] == fv[2]) {
      t.face_degenerate[f] = 1;
      ++t.report.degenerate_faces;
    } else if (face_area_3d(mesh, f) == 0.0) {
      ++t.report.zero_area_faces;
    }
    for (int k = 0; k < 3; ++k) {
      int a = fv[static_cast<size_t>(k)], b = fv[static_cast<size_t>((k + 1) % 3)];
      if (a > b) std::swap(a, b);
      recs.push_back({a, b, static_cast<int>(f), k});
    }
  }
  std::sort(recs.begin(), recs.end(), [](const Rec& x, const Rec& y) {
    if (x.a != y.a) return x.a < y.a;
    if (x.b != y.b) return x.b < y.b;
    if (x.face != y.face) return x.face < y.face;
    return x.local < y.local;
  });
  return recs;
}

// Builds t.edges, edge_faces and face_edge from the sorted side records (one edge per run of
// equal (a, b)); counts boundary and non-manifold edges (not those of a degenerate side) and edges.
void build_edge_table(const std::vector<Rec>& recs, size_t nf, Topology& t) {
  t.face_edge.assign(nf, {-1, -1, -1});
  t.edge_faces.reserve(recs.size());
  for (size_t i = 0; i < recs.size();) {
    size_t j = i;
    Edge e;
    e.a = recs[i].a;
    e.b = recs[i].b;
    e.first_incidence = static_cast<int>(t.edge_faces.size());
    const int id = static_cast<int>(t.edges.size());
    while (j < recs.size() && recs[j].a == e.a && recs[j].b == e.b) {
      t.edge_faces.push_back({recs[j].face, recs[j].local});
      t.face_edge[static_cast<size_t>(recs[j].face)][static_cast<size_t>(recs[j].local)] = id;
      ++j;
    }
    e.num_faces = static_cast<int>(j - i);
    if (e.a != e.b) {
      if (e.num_faces == 1) ++t.report.boundary_edges;
      if (e.num_faces > 2) ++t.report.non_manifold_edges;
    }
    t.edges.push_back(e);
    i = j;
  }
  t.report.edges = t.edges.size();
}

// Counts in t.report.duplicate_faces the non-degenerate faces whose welded vertex set equals that
// of the face before them in sorted order.
void count_duplicate_faces(Topology& t) {
  const size_t nf = t.face_vertex.size();
  std::vector<std::array<int, 3>> keys(nf);
  std::vector<int> order(nf);
  for (size_t f = 0; f < nf; ++f) {
    keys[f] = t.face_vertex[f];
    std::sort(keys[f].begin(), keys[f].end());
  }
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int x, int y) { return keys[static_cast<size_t>(x)] < keys[static_cast<size_t>(y)]; });
  for (size_t i = 1; i < order.size(); ++i)
    if (keys[static_cast<size_t>(order[i])] == keys[static_cast<size_t>(order[i - 1])] &&
        !t.face_degenerate[static_cast<size_t>(order[i])])
      ++t.report.duplicate_faces;
}

// Non-degenerate faces around each vertex, compressed: faces of v are vf[count[v] .. count[v+1]),
// in face order.
void faces_around_vertices(const Topology& t, std::vector<int>& count, std::vector<int>& vf) {
  const size_t nv = t.num_vertices(), nf = t.face_vertex.size();
  count.assign(nv + 1, 0);
  for (size_t f = 0; f < nf; ++f)
    if (!t.face_degenerate[f])
      for (int v : t.face_vertex[f]) ++count[static_cast<size_t>(v) + 1];
  std::partial_sum(count.begin(), count.end(), count.begin());
  vf.assign(static_cast<size_t>(count[nv]), 0);
  std::vector<int> fill(count.begin(), count.end() - 1);
  for (size_t f = 0; f < nf; ++f)
    if (!t.face_degenerate[f])
      for (int v : t.face_vertex[f]) vf[static_cast<size_t>(fill[static_cast<size_t>(v)]++)] = static_cast<int>(f);
}

// True when the faces around v (faces, more than one) do not form one sheet: a flood from the
// first face across manifold edges containing v misses some, or meets a non-manifold edge.
// mark (one entry per face) is scratch: faces reached are set to v.
bool vertex_is_non_manifold(const Topology& t, int v, const int* faces, int num_faces, std::vector<int>& mark,
                            std::vector<int>& stack) {
  stack.assign(1, faces[0]);
  mark[static_cast<size_t>(faces[0])] = v;
  int reached = 1;
  bool non_manifold_edge = false;
  while (!stack.empty()) {
    const int f = stack.back();
    stack.pop_back();
    for (int k = 0; k < 3; ++k) {
      const Edge& ed = t.edges[static_cast<size_t>(t.face_edge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
      if (ed.a != v && ed.b != v) continue;
      if (ed.num_faces > 2) non_manifold_edge = true;
      if (ed.num_faces != 2) continue;
      const int g = t.opposite_face(f, k);
      if (g >= 0 && mark[static_cast<size_t>(g)] != v && !t.face_degenerate[static_cast<size_t>(g)]) {
        mark[static_cast<size_t>(g)] = v;
        ++reached;
        stack.push_back(g);
      }
    }
  }
  return reached != num_faces || non_manifold_edge;
}

// Counts in t.report.non_manifold_vertices the vertices whose faces do not form one sheet.
void count_non_manifold_vertices(Topology& t) {
  std::vector<int> count, vf;
  faces_around_vertices(t, count, vf);
  std::vector<int> mark(t.face_vertex.size(), -1);
  std::vector<int> stack;
  for (size_t v = 0; v < t.num_vertices(); ++v) {
    const int b = count[v], e = count[v + 1];
    if (e - b <= 1) continue;
    if (vertex_is_non_manifold(t, static_cast<int>(v), vf.data() + b, e - b, mark, stack))
      ++t.report.non_manifold_vertices;
  }
}

}  // namespace

Topology build_topology(const TexturedMesh& mesh) {
  Topology t;
  weld_vertices(mesh, t);
  build_edge_table(classify_faces_and_sides(mesh, t), mesh.faces.size(), t);
  count_duplicate_faces(t);
  count_non_manifold_vertices(t);
  return t;
}

double face_area_3d(const TexturedMesh& mesh, size_t f) {
  const Vec3& a = mesh.corner_position(f, 0);
  const Vec3& b = mesh.corner_position(f, 1);
  const Vec3& c = mesh.corner_position(f, 2);
  return 0.5 * (b - a).cross(c - a).norm();
}

Vec3 face_normal(const TexturedMesh& mesh, size_t f) {
  const Vec3& a = mesh.corner_position(f, 0);
  const Vec3& b = mesh.corner_position(f, 1);
  const Vec3& c = mesh.corner_position(f, 2);
  Vec3 n = (b - a).cross(c - a);
  const double l = n.norm();
  return l > 0 ? Vec3(n / l) : Vec3::Zero();
}

}  // namespace texdefrag
