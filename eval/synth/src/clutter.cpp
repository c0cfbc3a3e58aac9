// Trees and ground clutter around a synthetic building (SynthOptions::clutter_fraction): real
// oblique-aerial tiles hold vegetation and street furniture whose irregular, strongly curved
// surfaces fragment the atlas into many small charts. Trees are a trunk (4 quads) and a canopy (an
// icosahedron subdivided once, vertices pushed in or out by up to 25%: 80 planar facets sharing
// one curved surface id, class vegetation); clutter is cars (a two-tier box) and bins or bushes
// (small boxes), class detail. Objects stand on the ground patch outside the building's bounding
// box (1 m clearance) and never overlap each other's footprint discs.
#include "internal.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace texdefrag::synth::detail {
namespace {

double polygon_area(const Polygon& p) {
  auto ring = [&](const std::vector<Vec3>& r) {
    Vec3 s = Vec3::Zero();
    for (size_t i = 0; i < r.size(); ++i) s += r[i].cross(r[(i + 1) % r.size()]);
    return 0.5 * std::abs(s.dot(p.normal));
  };
  double a = ring(p.outer);
  for (const auto& h : p.holes) a -= ring(h);
  return std::max(0.0, a);
}

class ClutterBuilder {
 public:
  ClutterBuilder(Shape& shape, Rng& rng) : s_(shape), rng_(rng) {}

  int plane(SemanticClass c, const Vec3& n, const Vec3& p, bool curved) {
    PlaneInfo pl;
    pl.semantic = c;
    pl.normal = n.normalized();
    pl.offset = pl.normal.dot(p);
    pl.curved = curved;
    s_.planes.push_back(pl);
    s_.plane_glass.push_back(0);
    return static_cast<int>(s_.planes.size()) - 1;
  }
  /// Adds a polygon; returns its area.
  double poly(std::vector<Vec3> ring, int plane_id, const Vec3& normal) {
    Polygon p;
    p.outer = std::move(ring);
    p.normal = normal.normalized();
    p.plane = plane_id;
    s_.polygons.push_back(std::move(p));
    return polygon_area(s_.polygons.back());
  }
  /// A box (no bottom; no top unless `top`) of size (lx, ly, lz) at footprint centre c, rotated
  /// by yaw; each side its own plane. Returns its area.
  double box(const Vec2& c, double lx, double ly, double z0, double lz, double yaw, SemanticClass cls, bool top = true) {
    const Vec2 ax(std::cos(yaw), std::sin(yaw)), ay(-std::sin(yaw), std::cos(yaw));
    std::array<Vec2, 4> fp;
    const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
    for (int i = 0; i < 4; ++i) fp[static_cast<size_t>(i)] = c + 0.5 * (sx[i] * lx * ax + sy[i] * ly * ay);
    double area = 0;
    for (int i = 0; i < 4; ++i) {
      const Vec2& a = fp[static_cast<size_t>(i)];
      const Vec2& b = fp[static_cast<size_t>((i + 1) % 4)];
      const Vec2 m = 0.5 * (a + b) - c;
      const Vec3 n(m.x(), m.y(), 0);
      const Vec3 A(a.x(), a.y(), z0), B(b.x(), b.y(), z0);
      area += poly({A, B, B + Vec3(0, 0, lz), A + Vec3(0, 0, lz)}, plane(cls, n, A, false), n);
    }
    if (!top) return area;
    std::vector<Vec3> lid;
    for (const Vec2& p : fp) lid.emplace_back(p.x(), p.y(), z0 + lz);
    area += poly(lid, plane(cls, Vec3::UnitZ(), lid[0], false), Vec3::UnitZ());
    return area;
  }
  double tree(const Vec2& c, double radius) {
    const double trunk_h = rng_.uniform(1.5, 3.0), tr = rng_.uniform(0.12, 0.25);
    // the trunk's top is inside the canopy
    double area = box(c, 2 * tr, 2 * tr, 0, trunk_h + 0.5 * radius, rng_.uniform(0, 3.14159), SemanticClass::Vegetation, false);
    const Vec3 centre(c.x(), c.y(), trunk_h + radius);
    const int surf = plane(SemanticClass::Vegetation, Vec3::UnitZ(), centre, true);
    for (const auto& t : canopy(centre, radius)) {
      const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
      if (n.norm() < 1e-9) continue;
      area += poly({t[0], t[1], t[2]}, surf, n);
    }
    return area;
  }

 private:
  /// Facets of a subdivided icosahedron around `centre` with jittered radii, outward winding.
  std::vector<std::array<Vec3, 3>> canopy(const Vec3& centre, double radius) {
    const double g = (1 + std::sqrt(5.0)) / 2;
    std::vector<Vec3> v = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                           {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                         {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                                         {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (Vec3& p : v) p.normalize();
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[static_cast<size_t>(a)] + v[static_cast<size_t>(b)]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> f2;
    for (const auto& t : f) {
      const int a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      f2.push_back({t[0], a, c});
      f2.push_back({t[1], b, a});
      f2.push_back({t[2], c, b});
      f2.push_back({a, b, c});
    }
    for (Vec3& p : v) p = centre + radius * rng_.uniform(0.75, 1.25) * Vec3(p.x(), p.y(), 0.8 * p.z());
    std::vector<std::array<Vec3, 3>> out;
    for (const auto& t : f2) {
      std::array<Vec3, 3> tri = {v[static_cast<size_t>(t[0])], v[static_cast<size_t>(t[1])], v[static_cast<size_t>(t[2])]};
      if ((tri[1] - tri[0]).cross(tri[2] - tri[0]).dot((tri[0] + tri[1] + tri[2]) / 3.0 - centre) < 0)
        std::swap(tri[1], tri[2]);
      out.push_back(tri);
    }
    return out;
  }

  Shape& s_;
  Rng& rng_;
};

}  // namespace

void add_clutter(Shape& shape, double fraction, Rng& rng) {
  if (fraction <= 0) return;
  double building = 0, ground_lo_x = 1e300, ground_lo_y = 1e300, ground_hi_x = -1e300, ground_hi_y = -1e300;
  for (const Polygon& p : shape.polygons) {
    building += polygon_area(p);
    if (shape.planes[static_cast<size_t>(p.plane)].semantic != SemanticClass::Ground) continue;
    for (const Vec3& q : p.outer) {
      ground_lo_x = std::min(ground_lo_x, q.x());
      ground_lo_y = std::min(ground_lo_y, q.y());
      ground_hi_x = std::max(ground_hi_x, q.x());
      ground_hi_y = std::max(ground_hi_y, q.y());
    }
  }
  if (ground_lo_x > ground_hi_x) return;
  shape.clutter_planes_from = static_cast<int>(shape.planes.size());
  const double target = building * fraction / (1 - fraction);  // clutter / (building + clutter) = fraction
  ClutterBuilder b(shape, rng);
  std::vector<std::pair<Vec2, double>> discs;  // footprints taken: centre, radius
  double area = 0;
  for (int attempt = 0; attempt < 4000 && area < target; ++attempt) {
    const double kind = rng.uniform();
    const double r = kind < 0.6 ? rng.uniform(1.5, 3.5) : kind < 0.85 ? 2.4 : 0.7;
    const Vec2 c(rng.uniform(ground_lo_x + r + 0.5, ground_hi_x - r - 0.5), rng.uniform(ground_lo_y + r + 0.5, ground_hi_y - r - 0.5));
    // outside the building's box with 1 m clearance, clear of other objects
    if (c.x() + r > shape.bbox_min.x() - 1 && c.x() - r < shape.bbox_max.x() + 1 && c.y() + r > shape.bbox_min.y() - 1 &&
        c.y() - r < shape.bbox_max.y() + 1)
      continue;
    bool free = true;
    for (const auto& [d, rd] : discs) free = free && (c - d).norm() > r + rd + 0.3;
    if (!free) continue;
    discs.emplace_back(c, r);
    const double yaw = rng.uniform(0, 3.141592653589793);
    if (kind < 0.6) {
      area += b.tree(c, r);
    } else if (kind < 0.85) {  // car: body and cabin
      area += b.box(c, 4.2, 1.8, 0.3, 0.8, yaw, SemanticClass::Detail);
      area += b.box(c, 2.2, 1.6, 1.1, 0.5, yaw, SemanticClass::Detail);
    } else {
      area += b.box(c, rng.uniform(0.6, 1.2), rng.uniform(0.6, 1.2), 0, rng.uniform(0.8, 1.4), yaw, SemanticClass::Detail);
    }
  }
}

}  // namespace texdefrag::synth::detail
