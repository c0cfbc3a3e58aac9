// Meshing of the synthetic buildings like a multi-view-stereo surface: every planar polygon gets
// an irregular triangulation (jittered hexagonal point grid + 2D Delaunay triangulation by
// Bowyer-Watson insertion, Bowyer 1981 / Watson 1981), with the points of shared polygon edges
// created once so that neighbouring planes join along common vertices. Then noise on positions and
// a few small holes.
#include "internal.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace texdefrag::synth::detail {
namespace {

/// Vertices merged when closer than 1e-6 m (corners computed by different polygons differ in the
/// last bits), found through a 1 mm hash grid.
class VertexPool {
 public:
  int find_or_add(const Vec3& p) {
    const std::array<int64_t, 3> c = cell(p);
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dz = -1; dz <= 1; ++dz) {
          auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (int id : it->second)
            if ((pos[static_cast<size_t>(id)] - p).squaredNorm() < 1e-12) return id;
        }
    pos.push_back(p);
    const int id = static_cast<int>(pos.size()) - 1;
    cells_[key(c)].push_back(id);
    return id;
  }
  std::vector<Vec3> pos;

 private:
  static std::array<int64_t, 3> cell(const Vec3& p) {
    return {static_cast<int64_t>(std::floor(p.x() * 1e3)), static_cast<int64_t>(std::floor(p.y() * 1e3)),
            static_cast<int64_t>(std::floor(p.z() * 1e3))};
  }
  static uint64_t key(const std::array<int64_t, 3>& c) {
    return Rng::mix(static_cast<uint64_t>(c[0]) * 0x9E3779B1ull ^ Rng::mix(static_cast<uint64_t>(c[1]) ^ (static_cast<uint64_t>(c[2]) << 21)));
  }
  std::unordered_map<uint64_t, std::vector<int>> cells_;
};

double orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// True when d is strictly inside the circumcircle of counter-clockwise triangle abc.
bool in_circle(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double adx = a.x() - d.x(), ady = a.y() - d.y();
  const double bdx = b.x() - d.x(), bdy = b.y() - d.y();
  const double cdx = c.x() - d.x(), cdy = c.y() - d.y();
  const double ad = adx * adx + ady * ady, bd = bdx * bdx + bdy * bdy, cd = cdx * cdx + cdy * cdy;
  return adx * (bdy * cd - bd * cdy) - ady * (bdx * cd - bd * cdx) + ad * (bdx * cdy - bdy * cdx) > 0;
}

/// Incremental Delaunay triangulation (Bowyer-Watson) with walking point location.
class Delaunay {
 public:
  struct Tri {
    std::array<int, 3> v;  ///< counter-clockwise
    std::array<int, 3> n;  ///< neighbour across the edge opposite v[i], -1 none
  };

  explicit Delaunay(std::vector<Vec2> pts) : p_(std::move(pts)) {
    Vec2 lo = p_[0], hi = p_[0];
    for (const Vec2& q : p_) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    const Vec2 c = 0.5 * (lo + hi);
    const double r = std::max(1.0, (hi - lo).norm()) * 20;
    n_real_ = static_cast<int>(p_.size());
    p_.emplace_back(c.x() - 2 * r, c.y() - r);
    p_.emplace_back(c.x() + 2 * r, c.y() - r);
    p_.emplace_back(c.x(), c.y() + 2 * r);
    tris_.push_back({{n_real_, n_real_ + 1, n_real_ + 2}, {-1, -1, -1}});
    dead_.push_back(0);
  }

  void insert_all() {
    for (int k = 0; k < n_real_; ++k) insert(k);
  }

  /// Triangles not touching the super-triangle.
  std::vector<std::array<int, 3>> triangles() const {
    std::vector<std::array<int, 3>> out;
    for (size_t t = 0; t < tris_.size(); ++t) {
      if (dead_[t]) continue;
      const auto& v = tris_[t].v;
      if (v[0] >= n_real_ || v[1] >= n_real_ || v[2] >= n_real_) continue;
      out.push_back(v);
    }
    return out;
  }

 private:
  int locate(const Vec2& q) {
    int t = last_;
    if (t < 0 || dead_[static_cast<size_t>(t)]) t = first_alive();
    for (size_t steps = 0; steps < tris_.size() + 8; ++steps) {
      const Tri& T = tris_[static_cast<size_t>(t)];
      int next = -1;
      for (int i = 0; i < 3; ++i) {
        const int e = (i + static_cast<int>(steps)) % 3;  // rotate the start edge: no cycling
        const Vec2& a = p_[static_cast<size_t>(T.v[(e + 1) % 3])];
        const Vec2& b = p_[static_cast<size_t>(T.v[(e + 2) % 3])];
        if (orient(a, b, q) < 0 && T.n[e] >= 0) {
          next = T.n[e];
          break;
        }
      }
      if (next < 0) return t;
      t = next;
    }
    return t;
  }
  int first_alive() const {
    for (size_t t = 0; t < tris_.size(); ++t)
      if (!dead_[t]) return static_cast<int>(t);
    return 0;
  }

  void insert(int k) {
    const Vec2& q = p_[static_cast<size_t>(k)];
    const int t0 = locate(q);
    cavity_.clear();
    cavity_.push_back(t0);
    mark_.resize(tris_.size(), 0);
    mark_[static_cast<size_t>(t0)] = 1;
    for (size_t i = 0; i < cavity_.size(); ++i) {
      const Tri& T = tris_[static_cast<size_t>(cavity_[i])];
      for (int e = 0; e < 3; ++e) {
        const int nb = T.n[e];
        if (nb < 0 || mark_[static_cast<size_t>(nb)]) continue;
        const Tri& N = tris_[static_cast<size_t>(nb)];
        if (in_circle(p_[static_cast<size_t>(N.v[0])], p_[static_cast<size_t>(N.v[1])], p_[static_cast<size_t>(N.v[2])], q)) {
          mark_[static_cast<size_t>(nb)] = 1;
          cavity_.push_back(nb);
        }
      }
    }
    // boundary of the cavity, each edge (a, b) counter-clockwise with its outside neighbour
    border_.clear();
    for (int t : cavity_) {
      const Tri& T = tris_[static_cast<size_t>(t)];
      for (int e = 0; e < 3; ++e) {
        const int nb = T.n[e];
        if (nb >= 0 && mark_[static_cast<size_t>(nb)]) continue;
        border_.push_back({T.v[(e + 1) % 3], T.v[(e + 2) % 3], nb});
      }
    }
    for (int t : cavity_) {
      dead_[static_cast<size_t>(t)] = 1;
      mark_[static_cast<size_t>(t)] = 0;
    }
    size_t reuse = 0;
    created_.clear();
    for (const auto& be : border_) {
      int id;
      if (reuse < cavity_.size()) {
        id = cavity_[reuse++];
        dead_[static_cast<size_t>(id)] = 0;
      } else {
        id = static_cast<int>(tris_.size());
        tris_.push_back({});
        dead_.push_back(0);
        mark_.push_back(0);
      }
      tris_[static_cast<size_t>(id)] = {{be.a, be.b, k}, {-1, -1, be.outside}};
      if (be.outside >= 0) {
        Tri& O = tris_[static_cast<size_t>(be.outside)];
        for (int e = 0; e < 3; ++e)
          if (O.v[(e + 1) % 3] == be.b && O.v[(e + 2) % 3] == be.a) O.n[e] = id;
      }
      created_.push_back(id);
    }
    // link the fan: tri (a, b, k): n[0] is across (b, k) = the tri starting at b; n[1] across (k, a)
    for (int id : created_) {
      Tri& T = tris_[static_cast<size_t>(id)];
      for (int other : created_) {
        const Tri& O = tris_[static_cast<size_t>(other)];
        if (O.v[0] == T.v[1]) T.n[0] = other;
        if (O.v[1] == T.v[0]) T.n[1] = other;
      }
    }
    last_ = created_.empty() ? -1 : created_.back();
  }

  std::vector<Vec2> p_;
  int n_real_ = 0;
  std::vector<Tri> tris_;
  std::vector<uint8_t> dead_, mark_;
  std::vector<int> cavity_, created_;
  int last_ = -1;
  struct BorderEdge { int a, b, outside; };
  std::vector<BorderEdge> border_;
};

/// Even-odd point-in-polygon over several rings.
bool inside(const std::vector<std::vector<Vec2>>& rings, const Vec2& q) {
  bool in = false;
  for (const auto& r : rings)
    for (size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
      const Vec2& a = r[i];
      const Vec2& b = r[j];
      if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
        in = !in;
    }
  return in;
}

double dist2_to_rings(const std::vector<std::vector<Vec2>>& rings, const Vec2& q) {
  double best = 1e300;
  for (const auto& r : rings)
    for (size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
      const Vec2 ab = r[i] - r[j];
      const double l2 = ab.squaredNorm();
      const double t = l2 > 0 ? std::clamp((q - r[j]).dot(ab) / l2, 0.0, 1.0) : 0.0;
      best = std::min(best, (r[j] + t * ab - q).squaredNorm());
    }
  return best;
}

/// Corners of all polygons, bucketed in a 1 m grid, to split polygon edges at T-junctions.
class CornerGrid {
 public:
  void add(int id, const Vec3& p) { cells_[key(p)].push_back(id); }
  /// Corner ids lying inside segment (a, b) (not at its ends), sorted along it.
  std::vector<int> on_segment(const std::vector<Vec3>& pos, int ia, int ib) const {
    const Vec3& a = pos[static_cast<size_t>(ia)];
    const Vec3& b = pos[static_cast<size_t>(ib)];
    const Vec3 d = b - a;
    const double len2 = d.squaredNorm();
    std::vector<std::pair<double, int>> hits;
    const Vec3 lo = a.cwiseMin(b), hi = a.cwiseMax(b);
    for (int64_t x = cell(lo.x()) - 1; x <= cell(hi.x()) + 1; ++x)
      for (int64_t y = cell(lo.y()) - 1; y <= cell(hi.y()) + 1; ++y)
        for (int64_t z = cell(lo.z()) - 1; z <= cell(hi.z()) + 1; ++z) {
          auto it = cells_.find(key3(x, y, z));
          if (it == cells_.end()) continue;
          for (int id : it->second) {
            if (id == ia || id == ib) continue;
            const Vec3& p = pos[static_cast<size_t>(id)];
            const double t = (p - a).dot(d) / len2;
            if (t <= 1e-9 || t >= 1 - 1e-9) continue;
            if ((a + t * d - p).squaredNorm() < 1e-10) hits.emplace_back(t, id);
          }
        }
    std::sort(hits.begin(), hits.end());
    std::vector<int> out;
    for (const auto& h : hits) out.push_back(h.second);
    return out;
  }

 private:
  static int64_t cell(double v) { return static_cast<int64_t>(std::floor(v)); }
  static uint64_t key3(int64_t x, int64_t y, int64_t z) {
    return Rng::mix(static_cast<uint64_t>(x) * 0x9E3779B1ull ^ Rng::mix(static_cast<uint64_t>(y) ^ (static_cast<uint64_t>(z) << 21)));
  }
  static uint64_t key(const Vec3& p) { return key3(cell(p.x()), cell(p.y()), cell(p.z())); }
  std::unordered_map<uint64_t, std::vector<int>> cells_;
};

}  // namespace

namespace {

/// The remesher's state across polygons: merged vertices, polygon corners, and the points of every
/// elementary boundary segment (between two corners), created once so that every polygon sharing a
/// segment uses the same points.
class Remesher {
 public:
  Remesher(const Shape& shape, double edge) : shape_(shape), edge_(edge) {}

  /// 1. Corners, merged across polygons.
  void add_corners() {
    ring_ids_.assign(shape_.polygons.size(), {});
    for (size_t pi = 0; pi < shape_.polygons.size(); ++pi) {
      const Polygon& P = shape_.polygons[pi];
      auto add_ring = [&](const std::vector<Vec3>& r) {
        std::vector<int> ids;
        for (const Vec3& p : r) {
          const size_t before = pool_.pos.size();
          const int id = pool_.find_or_add(p);
          if (pool_.pos.size() != before) corners_.add(id, p);
          if (ids.empty() || ids.back() != id) ids.push_back(id);
        }
        while (ids.size() > 1 && ids.front() == ids.back()) ids.pop_back();
        ring_ids_[pi].push_back(ids);
      };
      add_ring(P.outer);
      for (const auto& h : P.holes) add_ring(h);
    }
  }

  /// One pass over every polygon: boundary points, interior points drawn from rng, Delaunay
  /// triangulation, the triangles inside the polygon (when out). Boundary segments (consecutive
  /// boundary points) that are not edges of their polygon's triangulation go to `missing`.
  size_t pass(Rng& rng, bool out) {
    size_t predicted = 0;
    tris_.clear();
    face_plane_.clear();
    interior_pos_.clear();
    missing_.clear();
    pair_segment_.clear();
    for (size_t pi = 0; pi < shape_.polygons.size(); ++pi) predicted += polygon(pi, rng, out);
    return predicted;
  }

  /// Splits every missing boundary segment at its midpoint, in the shared point list of the
  /// elementary segment holding it (so every polygon along it gets the point). Returns how many.
  size_t split_missing() {
    size_t n = 0;
    for (const auto& [a, b] : missing_) {
      auto it = pair_segment_.find(pair_key(a, b));
      if (it == pair_segment_.end()) continue;
      const uint64_t key = it->second;
      std::vector<int> seq{static_cast<int>(key >> 32)};
      std::vector<int>& pts = segment_points_[key];
      seq.insert(seq.end(), pts.begin(), pts.end());
      seq.push_back(static_cast<int>(key & 0xffffffffu));
      for (size_t i = 0; i + 1 < seq.size(); ++i) {
        if (!((seq[i] == a && seq[i + 1] == b) || (seq[i] == b && seq[i + 1] == a))) continue;
        pool_.pos.push_back(0.5 * (pool_.pos[static_cast<size_t>(a)] + pool_.pos[static_cast<size_t>(b)]));
        pts.insert(pts.begin() + static_cast<std::ptrdiff_t>(i), static_cast<int>(pool_.pos.size()) - 1);
        ++n;
        break;
      }
    }
    return n;
  }

  /// The mesh of the last pass (interior vertices follow the pool's).
  void write(RawMesh* out) {
    const int base = static_cast<int>(pool_.pos.size());
    out->positions = pool_.pos;
    out->positions.insert(out->positions.end(), interior_pos_.begin(), interior_pos_.end());
    for (auto& f : tris_)
      for (int& id : f)
        if (id < 0) id = base + (-1 - id);
    out->tris = std::move(tris_);
    out->face_plane = std::move(face_plane_);
  }

 private:
  static uint64_t pair_key(int a, int b) {
    return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint64_t>(std::max(a, b));
  }
  /// The points inside elementary segment (a, b), from a to b (created on first use).
  std::vector<int> subdivide(int a, int b) {
    const int lo = std::min(a, b), hi = std::max(a, b);
    const uint64_t key = pair_key(lo, hi);
    auto it = segment_points_.find(key);
    if (it == segment_points_.end()) {
      const Vec3 A = pool_.pos[static_cast<size_t>(lo)], B = pool_.pos[static_cast<size_t>(hi)];
      const int n = std::max(1, static_cast<int>(std::lround((B - A).norm() / edge_)));
      std::vector<int> ids;
      for (int i = 1; i < n; ++i) {
        const double t = static_cast<double>(i) / n;
        pool_.pos.push_back(A + t * (B - A));
        ids.push_back(static_cast<int>(pool_.pos.size()) - 1);
      }
      it = segment_points_.emplace(key, std::move(ids)).first;
    }
    std::vector<int> pts = it->second;
    if (a != lo) std::reverse(pts.begin(), pts.end());
    return pts;
  }
  size_t polygon(size_t pi, Rng& rng, bool out);

  /// The frame of a polygon's plane: (u, v, normal) right-handed, origin at its first outer point.
  struct PlaneFrame {
    Vec3 u, v, origin;
    Vec2 to2(const Vec3& p) const { return Vec2((p - origin).dot(u), (p - origin).dot(v)); }
  };
  /// The points of one polygon being triangulated, in the frame's 2D coordinates.
  struct PolygonPoints {
    std::vector<std::vector<Vec2>> rings2;  ///< per kept ring (>= 3 ids): its corners
    std::vector<int> ids;  ///< per point: boundary vertex id, or interior (-1 - interior index)
    std::vector<Vec2> pts;
    std::vector<std::pair<size_t, size_t>> ring_range;  ///< [first, end) of each ring's points in pts
  };
  /// polygon's boundary: every ring of polygon pi (>= 3 corners) with the corners on its sides and
  /// their subdivisions, in order; records each boundary pair's elementary segment (pair_segment_).
  void boundary_points(size_t pi, const PlaneFrame& fr, PolygonPoints& pp);
  /// polygon's interior: a jittered hexagonal grid (offset and jitter from rng) inside the rings,
  /// kept 0.55 edge from them, rows in boustrophedon order; appended to pp and interior_pos_.
  void interior_points(Rng& rng, const PlaneFrame& fr, PolygonPoints& pp);
  /// Delaunay triangulation of pp: appends the triangles of non-negligible area inside the rings
  /// to tris_ (with `plane`) and the boundary segments it did not keep to missing_.
  void triangulate_points(const PolygonPoints& pp, int plane);

  const Shape& shape_;
  double edge_;
  VertexPool pool_;
  CornerGrid corners_;
  std::vector<std::vector<std::vector<int>>> ring_ids_;
  std::unordered_map<uint64_t, std::vector<int>> segment_points_;
  std::unordered_map<uint64_t, uint64_t> pair_segment_;  ///< boundary pair -> its elementary segment
  std::vector<std::pair<int, int>> missing_;
  std::vector<Vec3> interior_pos_;  ///< appended after the pool's vertices
  std::vector<std::array<int, 3>> tris_;
  std::vector<int> face_plane_;
};

void Remesher::boundary_points(size_t pi, const PlaneFrame& fr, PolygonPoints& pp) {
  for (const auto& ring : ring_ids_[pi]) {
    if (ring.size() < 3) continue;
    std::vector<Vec2> r2;
    const size_t first = pp.pts.size();
    for (size_t i = 0; i < ring.size(); ++i) {
      const int a = ring[i], b = ring[(i + 1) % ring.size()];
      r2.push_back(fr.to2(pool_.pos[static_cast<size_t>(a)]));
      std::vector<int> chain = corners_.on_segment(pool_.pos, a, b);
      chain.insert(chain.begin(), a);
      chain.push_back(b);
      for (size_t c = 0; c + 1 < chain.size(); ++c) {
        std::vector<int> seg{chain[c]};
        for (int m : subdivide(chain[c], chain[c + 1])) seg.push_back(m);
        seg.push_back(chain[c + 1]);
        for (size_t k = 0; k + 1 < seg.size(); ++k) {
          pair_segment_[pair_key(seg[k], seg[k + 1])] = pair_key(chain[c], chain[c + 1]);
          pp.ids.push_back(seg[k]);
          pp.pts.push_back(fr.to2(pool_.pos[static_cast<size_t>(seg[k])]));
        }
      }
    }
    pp.ring_range.emplace_back(first, pp.pts.size());
    pp.rings2.push_back(std::move(r2));
  }
}

void Remesher::interior_points(Rng& rng, const PlaneFrame& fr, PolygonPoints& pp) {
  const auto& rings2 = pp.rings2;
  Vec2 lo = rings2[0][0], hi = rings2[0][0];
  for (const auto& r : rings2)
    for (const Vec2& q : r) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  const double dy = edge_ * 0.8660254037844386;
  const double ox = rng.uniform(0, edge_), oy = rng.uniform(0, dy);
  const double keep2 = (0.55 * edge_) * (0.55 * edge_);
  int row = 0;
  for (double y = lo.y() + oy; y < hi.y(); y += dy, ++row) {
    std::vector<Vec2> line;
    for (double x = lo.x() + ox + (row % 2 ? edge_ / 2 : 0.0); x < hi.x(); x += edge_) {
      const Vec2 q(x + rng.uniform(-0.3, 0.3) * edge_, y + rng.uniform(-0.3, 0.3) * dy);
      if (!inside(rings2, q) || dist2_to_rings(rings2, q) < keep2) continue;
      line.push_back(q);
    }
    if (row % 2) std::reverse(line.begin(), line.end());  // boustrophedon: coherent insertion
    for (const Vec2& q : line) {
      pp.pts.push_back(q);
      pp.ids.push_back(-1 - static_cast<int>(interior_pos_.size()));
      interior_pos_.push_back(fr.origin + q.x() * fr.u + q.y() * fr.v);
    }
  }
}

void Remesher::triangulate_points(const PolygonPoints& pp, int plane) {
  const auto& pts = pp.pts;
  const auto& ids = pp.ids;
  Delaunay dt(pts);
  dt.insert_all();
  std::unordered_map<uint64_t, char> dt_edges;
  const double min_area = 1e-6 * edge_ * edge_;
  for (const auto& t : dt.triangles()) {
    for (int k = 0; k < 3; ++k) dt_edges[pair_key(t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)])] = 1;
    const Vec2& a = pts[static_cast<size_t>(t[0])];
    const Vec2& b = pts[static_cast<size_t>(t[1])];
    const Vec2& c = pts[static_cast<size_t>(t[2])];
    if (orient(a, b, c) < min_area) continue;
    if (!inside(pp.rings2, (a + b + c) / 3.0)) continue;
    std::array<int, 3> f;
    for (int k = 0; k < 3; ++k) f[static_cast<size_t>(k)] = ids[static_cast<size_t>(t[static_cast<size_t>(k)])];
    tris_.push_back(f);
    face_plane_.push_back(plane);
  }
  // A boundary segment the triangulation did not keep: triangles cross the polygon's boundary there
  // (their winding can disagree with the neighbouring polygon's).
  for (const auto& [first, end] : pp.ring_range)
    for (size_t i = first; i < end; ++i) {
      const size_t j = i + 1 < end ? i + 1 : first;
      if (!dt_edges.count(pair_key(static_cast<int>(i), static_cast<int>(j)))) missing_.emplace_back(ids[i], ids[j]);
    }
}

size_t Remesher::polygon(size_t pi, Rng& rng, bool out) {
  const Polygon& P = shape_.polygons[pi];
  // frame of the plane: (u, v, n) right-handed
  const Vec3 n = P.normal;
  const Vec3 ref = std::abs(n.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  PlaneFrame fr;
  fr.u = ref.cross(n).normalized();
  fr.v = n.cross(fr.u);
  fr.origin = P.outer[0];
  PolygonPoints pp;
  boundary_points(pi, fr, pp);
  if (pp.rings2.empty()) return 0;
  const size_t n_boundary = pp.pts.size();
  // interior: jittered hexagonal grid, kept away from the boundary
  interior_points(rng, fr, pp);
  const size_t n_interior = pp.pts.size() - n_boundary;
  const size_t predicted = 2 * n_interior + n_boundary + 2 * (pp.rings2.size() - 1) - 2;
  if (!out) return predicted;
  triangulate_points(pp, P.plane);
  return predicted;
}

/// Passes of the conforming refinement before giving up (each splits every missing segment).
constexpr int kMaxConformingPasses = 8;

}  // namespace

size_t remesh(const Shape& shape, double edge, Rng& rng, RawMesh* out) {
  Remesher r(shape, edge);
  r.add_corners();
  if (!out) return r.pass(rng, false);
  // Conforming: a boundary segment that is not an edge of its polygon's Delaunay triangulation is
  // split at its midpoint (in every polygon sharing it) and every polygon is meshed again with the
  // same interior points, until every boundary segment is kept.
  const Rng start = rng;
  for (int pass = 0;; ++pass) {
    rng = start;
    r.pass(rng, true);
    if (pass == kMaxConformingPasses || r.split_missing() == 0) break;
  }
  r.write(out);
  return out->tris.size();
}

void perturb(RawMesh& mesh, const Shape& shape, double sigma, int holes, Rng& rng) {
  (void)shape;
  if (sigma > 0)
    for (Vec3& p : mesh.positions) p += sigma * Vec3(rng.normal(), rng.normal(), rng.normal());
  if (holes <= 0 || mesh.tris.empty()) return;
  std::vector<Vec3> centroid(mesh.tris.size());
  for (size_t f = 0; f < mesh.tris.size(); ++f) {
    const auto& t = mesh.tris[f];
    centroid[f] = (mesh.positions[static_cast<size_t>(t[0])] + mesh.positions[static_cast<size_t>(t[1])] +
                   mesh.positions[static_cast<size_t>(t[2])]) / 3.0;
  }
  std::vector<uint8_t> drop(mesh.tris.size(), 0);
  for (int h = 0; h < holes; ++h) {
    const size_t c = static_cast<size_t>(rng.uniform_int(0, static_cast<int>(mesh.tris.size()) - 1));
    const double r2 = std::pow(rng.uniform(0.3, 0.8), 2);
    for (size_t f = 0; f < mesh.tris.size(); ++f)
      if ((centroid[f] - centroid[c]).squaredNorm() < r2) drop[f] = 1;
  }
  size_t w = 0;
  for (size_t f = 0; f < mesh.tris.size(); ++f) {
    if (drop[f]) continue;
    mesh.tris[w] = mesh.tris[f];
    mesh.face_plane[w] = mesh.face_plane[f];
    ++w;
  }
  mesh.tris.resize(w);
  mesh.face_plane.resize(w);
}

}  // namespace texdefrag::synth::detail
