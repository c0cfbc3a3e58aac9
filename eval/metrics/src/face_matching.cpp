// Face correspondence between an input and any tool's output by 3D triangle (not by index): tools
// such as the M-method's program (Maggiordomo et al. 2021) reorder faces, drop degenerate and
// non-manifold ones, re-orient some, and print positions with fewer digits.
#include "texdefrag/eval/metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_map>

namespace texdefrag::eval {
namespace {

uint64_t bits(double d) {
  if (d == 0.0) d = 0.0;  // note: +0 and -0 are the same coordinate (as in core/topology.cpp)
  uint64_t u;
  std::memcpy(&u, &d, sizeof u);
  return u;
}

struct Key3 {
  uint64_t x, y, z;
  bool operator==(const Key3& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct Key3Hash {
  size_t operator()(const Key3& k) const {
    uint64_t h = k.x * 0x9E3779B97F4A7C15ULL;
    h ^= k.y + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    h ^= k.z + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};
Key3 pos_key(const Vec3& p) { return {bits(p.x()), bits(p.y()), bits(p.z())}; }

struct CellKey {
  long long x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  size_t operator()(const CellKey& k) const {
    uint64_t h = static_cast<uint64_t>(k.x) * 0x9E3779B97F4A7C15ULL;
    h ^= static_cast<uint64_t>(k.y) + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    h ^= static_cast<uint64_t>(k.z) + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};

// Input positions (welded vertex ids) by exact key and, for the tolerance search, by grid cell.
struct InputIndex {
  std::unordered_map<Key3, int, Key3Hash> exact;
  std::unordered_map<CellKey, std::vector<int>, CellHash> grid;  // empty unless tol > 0
  double tol = 0;
};

const Vec3& vertex_position(const TexturedMesh& in, const Topology& topo, size_t v) {
  return in.positions[static_cast<size_t>(topo.position_of_vertex[v])];
}

// Grid cell of p for cells of edge tol (> 0).
CellKey cell_of(const Vec3& p, double tol) {
  // note: clamped so that absurd coordinate/tolerance ratios cannot overflow the conversion.
  const auto c = [&](double x) { return static_cast<long long>(std::clamp(std::floor(x / tol), -4e18, 4e18)); };
  return CellKey{c(p.x()), c(p.y()), c(p.z())};
}

// Indexes every welded input vertex of topo; the grid is built only when tol > 0.
InputIndex index_input(const TexturedMesh& in, const Topology& topo, double tol) {
  InputIndex index;
  index.tol = tol;
  const size_t nv_in = topo.num_vertices();
  index.exact.reserve(nv_in);
  for (size_t v = 0; v < nv_in; ++v) index.exact.emplace(pos_key(vertex_position(in, topo, v)), static_cast<int>(v));
  if (tol > 0)
    for (size_t v = 0; v < nv_in; ++v) index.grid[cell_of(vertex_position(in, topo, v), tol)].push_back(static_cast<int>(v));
  return index;
}

// Nearest input vertex within index.tol (> 0) of p, ties to the last one found; -1 if none.
int nearest_input_vertex(const InputIndex& index, const TexturedMesh& in, const Topology& topo, const Vec3& p) {
  const CellKey c = cell_of(p, index.tol);
  double best = index.tol;
  int id = -1;
  for (long long dz = -1; dz <= 1; ++dz)
    for (long long dy = -1; dy <= 1; ++dy)
      for (long long dx = -1; dx <= 1; ++dx) {
        auto g = index.grid.find(CellKey{c.x + dx, c.y + dy, c.z + dz});
        if (g == index.grid.end()) continue;
        for (int v : g->second) {
          const double d = (vertex_position(in, topo, static_cast<size_t>(v)) - p).norm();
          if (d <= best) {
            best = d;
            id = v;
          }
        }
      }
  return id;
}

// Input vertex id of each output position used by a face (-1 for unused positions): exact key,
// else nearest within the tolerance, else a fresh id >= nv_in (one per distinct output position).
// Counts m.exact_positions, snapped_positions and moved_positions.
std::vector<int> map_output_positions(const InputIndex& index, const TexturedMesh& in, const Topology& topo,
                                      const TexturedMesh& out, FaceMatch& m) {
  std::unordered_map<Key3, int, Key3Hash> out_ids;
  std::vector<int> id_of_out_position(out.positions.size(), -1);
  int next_fresh = static_cast<int>(topo.num_vertices());
  for (const Face& f : out.faces)
    for (int pi : f.v) {
      int& slot = id_of_out_position[static_cast<size_t>(pi)];
      if (slot >= 0) continue;
      const Vec3& p = out.positions[static_cast<size_t>(pi)];
      const Key3 key = pos_key(p);
      auto seen = out_ids.find(key);
      if (seen != out_ids.end()) {
        slot = seen->second;
        continue;
      }
      int id = -1;
      auto it = index.exact.find(key);
      if (it != index.exact.end()) {
        id = it->second;
        ++m.exact_positions;
      } else if (index.tol > 0) {
        id = nearest_input_vertex(index, in, topo, p);
        if (id >= 0) ++m.snapped_positions;
      }
      if (id < 0) {
        id = next_fresh++;
        ++m.moved_positions;
      }
      out_ids.emplace(key, id);
      slot = id;
    }
  return id_of_out_position;
}

using Triple = std::array<int, 3>;

// Each face's vertex-id triple (ids(f) for f in [0, n)), sorted so that orientation does not matter.
template <class Ids>
std::vector<Triple> sorted_triples(size_t n, Ids&& ids) {
  std::vector<Triple> k(n);
  for (size_t f = 0; f < n; ++f) {
    k[f] = ids(f);
    std::sort(k[f].begin(), k[f].end());
  }
  return k;
}

// Face indices [0, k.size()) ordered by triple, then by index.
std::vector<int> order_by_triple(const std::vector<Triple>& k) {
  std::vector<int> order(k.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&k](int a, int b) {
    const auto& ka = k[static_cast<size_t>(a)];
    const auto& kb = k[static_cast<size_t>(b)];
    return ka != kb ? ka < kb : a < b;
  });
  return order;
}

// Sets m.output_corner[fi]: for each corner of input face fi, the corner of output face fo at the
// same position (each output corner used once: degenerate faces repeat a position).
void match_corners(const Topology& topo, const TexturedMesh& out, const std::vector<int>& id_of_out_position, int fi,
                   int fo, FaceMatch& m) {
  bool used[3] = {false, false, false};
  for (int k = 0; k < 3; ++k) {
    const int vid = topo.face_vertex[static_cast<size_t>(fi)][static_cast<size_t>(k)];
    for (int l = 0; l < 3; ++l)
      if (!used[l] && id_of_out_position[static_cast<size_t>(out.faces[static_cast<size_t>(fo)].v[static_cast<size_t>(l)])] == vid) {
        used[l] = true;
        m.output_corner[static_cast<size_t>(fi)][static_cast<size_t>(k)] = l;
        break;
      }
  }
}

// Multiset matching of the input's and the output's triples (kin, kout): equal triples pair up in
// index order. Fills m's face and corner maps and m.matched, added, lost.
void match_triples(const Topology& topo, const TexturedMesh& out, const std::vector<int>& id_of_out_position,
                   const std::vector<Triple>& kin, const std::vector<Triple>& kout, FaceMatch& m) {
  const std::vector<int> oin = order_by_triple(kin), oout = order_by_triple(kout);
  m.output_of_input.assign(kin.size(), -1);
  m.input_of_output.assign(kout.size(), -1);
  m.output_corner.assign(kin.size(), {-1, -1, -1});
  for (size_t i = 0, j = 0; i < oin.size() && j < oout.size();) {
    const auto& a = kin[static_cast<size_t>(oin[i])];
    const auto& b = kout[static_cast<size_t>(oout[j])];
    if (a < b) {
      ++i;
    } else if (b < a) {
      ++j;
    } else {
      const int fi = oin[i++], fo = oout[j++];
      m.output_of_input[static_cast<size_t>(fi)] = fo;
      m.input_of_output[static_cast<size_t>(fo)] = fi;
      ++m.matched;
      match_corners(topo, out, id_of_out_position, fi, fo, m);
    }
  }
  m.added = kout.size() - m.matched;
  m.lost = kin.size() - m.matched;
}

// Why were faces lost? Counts each unmatched input face as degenerate, zero 3D area, on a
// non-manifold edge of the input, or other (in that order of precedence).
void count_lost_reasons(const TexturedMesh& in, const Topology& topo, FaceMatch& m) {
  for (size_t f = 0; f < in.faces.size(); ++f) {
    if (m.output_of_input[f] >= 0) continue;
    if (topo.face_degenerate[f]) {
      ++m.lost_degenerate;
    } else if (face_area_3d(in, f) == 0.0) {
      ++m.lost_zero_area;
    } else {
      bool nm = false;
      for (int e : topo.face_edge[f]) nm = nm || topo.edges[static_cast<size_t>(e)].num_faces > 2;
      if (nm)
        ++m.lost_non_manifold;
      else
        ++m.lost_other;
    }
  }
}

}  // namespace

FaceMatch match_faces(const TexturedMesh& in, const TexturedMesh& out, const MatchOptions& options) {
  const Topology topo = build_topology(in);
  const InputIndex index = index_input(in, topo, options.position_tolerance);
  FaceMatch m;
  const std::vector<int> id_of_out_position = map_output_positions(index, in, topo, out, m);
  const auto kin = sorted_triples(in.faces.size(), [&](size_t f) { return topo.face_vertex[f]; });
  const auto kout = sorted_triples(out.faces.size(), [&](size_t f) {
    const auto& v = out.faces[f].v;
    return Triple{id_of_out_position[static_cast<size_t>(v[0])], id_of_out_position[static_cast<size_t>(v[1])],
                  id_of_out_position[static_cast<size_t>(v[2])]};
  });
  match_triples(topo, out, id_of_out_position, kin, kout, m);
  count_lost_reasons(in, topo, m);
  return m;
}

}  // namespace texdefrag::eval
