// Face correspondence between an input and any tool's output by 3D triangle (not by index): tools
// such as the M-method's program (Maggiordomo et al. 2021) reorder faces, drop degenerate and
// non-manifold ones, re-orient some, and print positions with fewer digits.
#include "texdefrag/eval/metrics.h"

#include <algorithm>
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

}  // namespace

FaceMatch match_faces(const TexturedMesh& in, const TexturedMesh& out, const MatchOptions& options) {
  const Topology topo = build_topology(in);
  const size_t nv_in = topo.num_vertices();
  const double tol = options.position_tolerance;

  // Input positions (welded ids) by exact key and, for the tolerance search, by grid cell.
  std::unordered_map<Key3, int, Key3Hash> exact;
  exact.reserve(nv_in);
  for (size_t v = 0; v < nv_in; ++v)
    exact.emplace(pos_key(in.positions[static_cast<size_t>(topo.position_of_vertex[v])]), static_cast<int>(v));
  std::unordered_map<CellKey, std::vector<int>, CellHash> grid;
  const auto cell_of = [&](const Vec3& p) {
    // note: clamped so that absurd coordinate/tolerance ratios cannot overflow the conversion.
    const auto c = [&](double x) { return static_cast<long long>(std::clamp(std::floor(x / tol), -4e18, 4e18)); };
    return CellKey{c(p.x()), c(p.y()), c(p.z())};
  };
  if (tol > 0)
    for (size_t v = 0; v < nv_in; ++v)
      grid[cell_of(in.positions[static_cast<size_t>(topo.position_of_vertex[v])])].push_back(static_cast<int>(v));

  FaceMatch m;
  // Output positions -> input vertex ids; unmatched positions get fresh ids >= nv_in (one per
  // distinct output position).
  std::unordered_map<Key3, int, Key3Hash> out_ids;
  std::vector<int> id_of_out_position(out.positions.size(), -1);
  int next_fresh = static_cast<int>(nv_in);
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
      auto it = exact.find(key);
      if (it != exact.end()) {
        id = it->second;
        ++m.exact_positions;
      } else if (tol > 0) {
        const CellKey c = cell_of(p);
        double best = tol;
        for (long long dz = -1; dz <= 1; ++dz)
          for (long long dy = -1; dy <= 1; ++dy)
            for (long long dx = -1; dx <= 1; ++dx) {
              auto g = grid.find(CellKey{c.x + dx, c.y + dy, c.z + dz});
              if (g == grid.end()) continue;
              for (int v : g->second) {
                const double d = (in.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(v)])] - p).norm();
                if (d <= best) {
                  best = d;
                  id = v;
                }
              }
            }
        if (id >= 0) ++m.snapped_positions;
      }
      if (id < 0) {
        id = next_fresh++;
        ++m.moved_positions;
      }
      out_ids.emplace(key, id);
      slot = id;
    }

  // Multiset matching on sorted vertex-id triples.
  auto keys_of = [](size_t n, auto&& ids) {
    std::vector<std::array<int, 3>> k(n);
    for (size_t f = 0; f < n; ++f) {
      k[f] = ids(f);
      std::sort(k[f].begin(), k[f].end());
    }
    return k;
  };
  const auto kin = keys_of(in.faces.size(), [&](size_t f) { return topo.face_vertex[f]; });
  const auto kout = keys_of(out.faces.size(), [&](size_t f) {
    const auto& v = out.faces[f].v;
    return std::array<int, 3>{id_of_out_position[static_cast<size_t>(v[0])], id_of_out_position[static_cast<size_t>(v[1])],
                              id_of_out_position[static_cast<size_t>(v[2])]};
  });
  std::vector<int> oin(in.faces.size()), oout(out.faces.size());
  std::iota(oin.begin(), oin.end(), 0);
  std::iota(oout.begin(), oout.end(), 0);
  auto by_key = [](const std::vector<std::array<int, 3>>& k) {
    return [&k](int a, int b) {
      const auto& ka = k[static_cast<size_t>(a)];
      const auto& kb = k[static_cast<size_t>(b)];
      return ka != kb ? ka < kb : a < b;
    };
  };
  std::sort(oin.begin(), oin.end(), by_key(kin));
  std::sort(oout.begin(), oout.end(), by_key(kout));

  m.output_of_input.assign(in.faces.size(), -1);
  m.input_of_output.assign(out.faces.size(), -1);
  m.output_corner.assign(in.faces.size(), {-1, -1, -1});
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
      // Corner correspondence by position (each output corner used once: degenerate faces repeat).
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
  }
  m.added = out.faces.size() - m.matched;
  m.lost = in.faces.size() - m.matched;

  // Why were faces lost? Degenerate, zero 3D area, or on a non-manifold edge of the input.
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
  return m;
}

}  // namespace texdefrag::eval
