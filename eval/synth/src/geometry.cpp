// Building shapes of the synthetic benchmark (issue 3): each archetype as planar polygons with
// plane ids and semantic classes. Polygons that meet share their corner points exactly (walls stand
// on the ground's footprint hole, roofs sit on wall tops, recesses and balconies are holes in their
// wall), so the mesher can join neighbouring planes.
//
// Conventions: a footprint ring is listed with the building on its left (outer rings
// counter-clockwise seen from above, courtyard rings clockwise); a wall built on edge a->b faces
// right of a->b, i.e. out of the building.
#include "internal.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace texdefrag::synth::detail {
namespace {

using Ring = std::vector<Vec2>;

/// Left normal of direction d (unit).
Vec2 left_of(const Vec2& d) { return {-d.y(), d.x()}; }

/// Moves every edge of a ring (building on the left) by d to its left (into the building).
Ring inset(const Ring& r, double d) {
  Ring out(r.size());
  const size_t n = r.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec2& prev = r[(i + n - 1) % n];
    const Vec2& cur = r[i];
    const Vec2& next = r[(i + 1) % n];
    const Vec2 n1 = left_of((cur - prev).normalized());
    const Vec2 n2 = left_of((next - cur).normalized());
    out[i] = cur + d * (n1 + n2) / (1.0 + n1.dot(n2));
  }
  return out;
}

std::vector<Vec3> lift(const Ring& r, double z) {
  std::vector<Vec3> out;
  out.reserve(r.size());
  for (const Vec2& p : r) out.emplace_back(p.x(), p.y(), z);
  return out;
}

Ring rect(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }

/// An opening in a wall, in the wall's (u along the wall, v up) coordinates, metres.
struct Opening {
  double u0, v0, u1, v1;
  bool balcony = false;  ///< a slab sticking out (depth outwards) instead of a recess (depth inwards)
  double depth = 0.2;
};

class Builder {
 public:
  explicit Builder(Rng& rng) : rng_(rng) {}

  int plane(SemanticClass c, const Vec3& n, const Vec3& p, bool curved = false) {
    PlaneInfo pl;
    pl.semantic = c;
    pl.normal = n.normalized();
    pl.offset = pl.normal.dot(p);
    pl.curved = curved;
    shape.planes.push_back(pl);
    shape.plane_glass.push_back(0);
    return static_cast<int>(shape.planes.size()) - 1;
  }

  void poly(std::vector<Vec3> outer, const Vec3& normal, int plane_id, std::vector<std::vector<Vec3>> holes = {}) {
    Polygon p;
    p.outer = std::move(outer);
    p.holes = std::move(holes);
    p.normal = normal.normalized();
    p.plane = plane_id;
    shape.polygons.push_back(std::move(p));
  }

  /// Polygon on a new plane of class c.
  void poly_new(SemanticClass c, std::vector<Vec3> outer, const Vec3& normal, std::vector<std::vector<Vec3>> holes = {}) {
    const int id = plane(c, normal, outer[0]);
    poly(std::move(outer), normal, id, std::move(holes));
  }

  /// A wall on footprint edge a->b standing at z0, whose outline in (u, v) wall coordinates is
  /// `profile` (counter-clockwise seen from outside, starting (0,0), (L,0), ...), with openings.
  void wall(const Vec2& a, const Vec2& b, double z0, const std::vector<Vec2>& profile,
            const std::vector<Opening>& openings, SemanticClass cls = SemanticClass::Wall) {
    const Vec2 d2 = (b - a).normalized();
    const Vec3 U(d2.x(), d2.y(), 0), Z(0, 0, 1), N(d2.y(), -d2.x(), 0);
    const Vec3 A(a.x(), a.y(), z0);
    auto P = [&](double u, double v, double w) -> Vec3 { return A + u * U + v * Z + w * N; };
    std::vector<Vec3> outer;
    for (const Vec2& q : profile) outer.push_back(P(q.x(), q.y(), 0));
    std::vector<std::vector<Vec3>> holes;
    for (const Opening& o : openings) {
      holes.push_back({P(o.u0, o.v0, 0), P(o.u1, o.v0, 0), P(o.u1, o.v1, 0), P(o.u0, o.v1, 0)});
      const double w = o.balcony ? o.depth : -o.depth;
      const SemanticClass dc = SemanticClass::Detail;
      // note: reveals/slab sides: normals point away from the opening's solid (into free space).
      const double s = o.balcony ? 1.0 : -1.0;
      poly_new(dc, {P(o.u0, o.v0, 0), P(o.u1, o.v0, 0), P(o.u1, o.v0, w), P(o.u0, o.v0, w)}, s * -Z);  // bottom
      poly_new(dc, {P(o.u0, o.v1, 0), P(o.u1, o.v1, 0), P(o.u1, o.v1, w), P(o.u0, o.v1, w)}, s * Z);   // top
      poly_new(dc, {P(o.u0, o.v0, 0), P(o.u0, o.v1, 0), P(o.u0, o.v1, w), P(o.u0, o.v0, w)}, s * -U);  // left
      poly_new(dc, {P(o.u1, o.v0, 0), P(o.u1, o.v1, 0), P(o.u1, o.v1, w), P(o.u1, o.v0, w)}, s * U);   // right
      poly_new(dc, {P(o.u0, o.v0, w), P(o.u1, o.v0, w), P(o.u1, o.v1, w), P(o.u0, o.v1, w)}, N);       // back/front
      if (!o.balcony) shape.plane_glass.back() = 1;
    }
    poly_new(cls, outer, N, holes);
  }

  /// Rectangular wall of length L and height H with openings.
  void plain_wall(const Vec2& a, const Vec2& b, double z0, double H, const std::vector<Opening>& openings) {
    const double L = (b - a).norm();
    wall(a, b, z0, {{0, 0}, {L, 0}, {L, H}, {0, H}}, openings);
  }

  /// Window recesses in a grid of floors and bays on a facade of length L, height H.
  std::vector<Opening> windows(double L, double H, double floor_h, double z_first, bool balconies) {
    std::vector<Opening> out;
    if (L < 3.0) return out;
    const double bay = rng_.uniform(2.4, 3.6);
    const int nb = static_cast<int>((L - 1.0) / bay);
    if (nb < 1) return out;
    const double ww = rng_.uniform(0.9, 1.5), wh = rng_.uniform(1.2, 1.7);
    const double step = (L - 1.0) / nb;
    const double depth = rng_.uniform(0.15, 0.3);
    for (double v0 = z_first; v0 + wh + 0.4 < H; v0 += floor_h) {
      for (int i = 0; i < nb; ++i) {
        const double uc = 0.5 + step * (i + 0.5);
        Opening o{uc - ww / 2, v0, uc + ww / 2, v0 + wh, false, depth};
        if (balconies && v0 > 2.0 && i % 2 == 0 && rng_.chance(0.6)) {
          // a slab below the window: 0.2 m thick, 1.0-1.4 m deep, wider than the window
          const double bw = std::min(step * 0.95, ww + 1.4);
          out.push_back({uc - bw / 2, v0 - 0.5, uc + bw / 2, v0 - 0.3, true, rng_.uniform(1.0, 1.4)});
        }
        out.push_back(o);
      }
    }
    return out;
  }

  /// Walls around every edge of a ring (building on the left) from z0 to z1.
  void ring_walls(const Ring& r, double z0, double z1, double floor_h, double z_first, bool with_windows) {
    for (size_t i = 0; i < r.size(); ++i) {
      const Vec2& a = r[i];
      const Vec2& b = r[(i + 1) % r.size()];
      const double L = (b - a).norm();
      plain_wall(a, b, z0, z1 - z0, with_windows ? windows(L, z1 - z0, floor_h, z_first, false) : std::vector<Opening>{});
    }
  }

  /// A box (detail) standing on a horizontal surface at z: its footprint must be cut from that
  /// surface by the caller (returned ring, lifted to z).
  std::vector<Vec3> roof_box(const Ring& fp, double z, double h, SemanticClass cls = SemanticClass::Detail) {
    for (size_t i = 0; i < fp.size(); ++i) {
      const Vec2& a = fp[i];
      const Vec2& b = fp[(i + 1) % fp.size()];
      const double L = (b - a).norm();
      wall(a, b, z, {{0, 0}, {L, 0}, {L, h}, {0, h}}, {}, cls);
    }
    poly_new(cls == SemanticClass::Wall ? SemanticClass::Roof : cls, lift(fp, z + h), Vec3::UnitZ());
    return lift(fp, z);
  }

  /// Random small boxes on a rectangle [x0,x1]x[y0,y1] at height z, avoiding `keep_out` rectangles.
  std::vector<std::vector<Vec3>> roof_boxes(double x0, double y0, double x1, double y1, double z, int n,
                                            std::vector<Eigen::Vector4d> keep_out) {
    std::vector<std::vector<Vec3>> holes;
    for (int k = 0, tries = 0; k < n && tries < 40; ++tries) {
      const double w = rng_.uniform(1.2, 3.5), d = rng_.uniform(1.2, 3.0);
      if (x1 - x0 < w + 2 || y1 - y0 < d + 2) break;
      const double bx = rng_.uniform(x0 + 1, x1 - 1 - w), by = rng_.uniform(y0 + 1, y1 - 1 - d);
      const Eigen::Vector4d r(bx - 0.8, by - 0.8, bx + w + 0.8, by + d + 0.8);
      bool clash = false;
      for (const auto& o : keep_out)
        if (r[0] < o[2] && o[0] < r[2] && r[1] < o[3] && o[1] < r[3]) clash = true;
      if (clash) continue;
      keep_out.push_back(r);
      holes.push_back(roof_box(rect(bx, by, bx + w, by + d), z, rng_.uniform(0.8, 2.2)));
      ++k;
    }
    return holes;
  }

  /// Flat roof over the region bounded by rings (building on the left of each) at height z, with a
  /// parapet of height ph (0: none; then the walls must end at z, else at z + ph). `extra_holes`
  /// are footprints of things standing on the roof (already built).
  void flat_roof(const std::vector<Ring>& rings, double z, double ph, std::vector<std::vector<Vec3>> extra_holes) {
    const int roof = plane(SemanticClass::Roof, Vec3::UnitZ(), Vec3(0, 0, z));
    std::vector<Ring> inner = rings;
    if (ph > 0) {
      const double t = rng_.uniform(0.25, 0.4);
      const int top = plane(SemanticClass::Detail, Vec3::UnitZ(), Vec3(0, 0, z + ph));
      for (size_t k = 0; k < rings.size(); ++k) {
        inner[k] = inset(rings[k], t);
        poly(lift(rings[k], z + ph), Vec3::UnitZ(), top, {lift(inner[k], z + ph)});
        for (size_t i = 0; i < inner[k].size(); ++i) {
          const Vec2& a = inner[k][i];
          const Vec2& b = inner[k][(i + 1) % inner[k].size()];
          const double L = (b - a).norm();
          wall(b, a, z, {{0, 0}, {L, 0}, {L, ph}, {0, ph}}, {}, SemanticClass::Detail);
        }
      }
    }
    std::vector<std::vector<Vec3>> holes;
    for (size_t k = 1; k < inner.size(); ++k) holes.push_back(lift(inner[k], z));
    for (auto& h : extra_holes) holes.push_back(std::move(h));
    poly(lift(inner[0], z), Vec3::UnitZ(), roof, holes);
  }

  /// A cylinder (stair tower, silo) of radius r and height h centred at c, with a flat top.
  /// Returns its footprint (to cut from the ground).
  std::vector<Vec3> cylinder(const Vec2& c, double r, double h) {
    const int n = std::clamp(static_cast<int>(std::lround(6.283185307179586 * r / 0.9)), 12, 48);
    const int surf = plane(SemanticClass::Wall, Vec3::UnitX(), Vec3(c.x(), c.y(), 0), true);
    Ring fp;
    for (int i = 0; i < n; ++i) {
      const double t = 6.283185307179586 * i / n;
      fp.emplace_back(c.x() + r * std::cos(t), c.y() + r * std::sin(t));
    }
    for (int i = 0; i < n; ++i) {
      const Vec2& a = fp[static_cast<size_t>(i)];
      const Vec2& b = fp[static_cast<size_t>((i + 1) % n)];
      const Vec2 m = 0.5 * (a + b) - c;
      const Vec3 nn = Vec3(m.x(), m.y(), 0).normalized();
      poly({Vec3(a.x(), a.y(), 0), Vec3(b.x(), b.y(), 0), Vec3(b.x(), b.y(), h), Vec3(a.x(), a.y(), h)}, nn, surf);
    }
    poly_new(SemanticClass::Roof, lift(fp, h), Vec3::UnitZ());
    shape.bbox_max.z() = std::max(shape.bbox_max.z(), h);
    return lift(fp, 0);
  }

  /// The ground patch around everything: a rectangle with the footprints cut out.
  void ground(std::vector<std::vector<Vec3>> footprints, const std::vector<Ring>& courtyards) {
    const double m = rng_.uniform(6.0, 12.0);
    Vec3 lo = shape.bbox_min, hi = shape.bbox_max;
    for (const auto& f : footprints)
      for (const Vec3& p : f) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    const int g = plane(SemanticClass::Ground, Vec3::UnitZ(), Vec3::Zero());
    poly(lift(rect(lo.x() - m, lo.y() - m, hi.x() + m, hi.y() + m), 0), Vec3::UnitZ(), g, std::move(footprints));
    for (const Ring& c : courtyards) poly(lift(c, 0), Vec3::UnitZ(), g);
  }

  void set_bbox(double x0, double y0, double x1, double y1, double zmax) {
    shape.bbox_min = Vec3(x0, y0, 0);
    shape.bbox_max = Vec3(x1, y1, std::max(zmax, shape.bbox_max.z()));
  }

  Shape shape;

 private:
  Rng& rng_;
};

/// Gable or hip roof over rectangle [0,L]x[0,W] (ridge along x) on walls of height H. Builds the
/// four walls too. Returns nothing; chimneys are cut into the first slope.
void pitched_house(Builder& b, Rng& rng, double L, double W, double H, double floor_h, bool hip) {
  const double rh = W / 2 * std::tan(rng.uniform(25.0, 40.0) * 3.141592653589793 / 180.0);
  const double hx = hip ? std::min(W / 2, L / 2 - 0.5) : 0.0;  // ridge inset from the gable ends
  const Vec3 p0(0, 0, H), p1(L, 0, H), p2(L, W, H), p3(0, W, H);
  const Vec3 r0(hx, W / 2, H + rh), r1(L - hx, W / 2, H + rh);
  // walls: the two long ones with windows and (front) balconies; gable ends are pentagons
  b.wall({0, 0}, {L, 0}, 0, {{0, 0}, {L, 0}, {L, H}, {0, H}}, b.windows(L, H, floor_h, 0.9, true));
  b.wall({L, W}, {0, W}, 0, {{0, 0}, {L, 0}, {L, H}, {0, H}}, b.windows(L, H, floor_h, 0.9, false));
  std::vector<Vec2> end = {{0, 0}, {W, 0}, {W, H}, {0, H}};
  if (!hip) end = {{0, 0}, {W, 0}, {W, H}, {W / 2, H + rh}, {0, H}};
  b.wall({L, 0}, {L, W}, 0, end, b.windows(W, H, floor_h, 0.9, false));
  b.wall({0, W}, {0, 0}, 0, end, b.windows(W, H, floor_h, 0.9, false));
  // slope 1 (facing -y) with chimneys
  const Vec3 n1 = (p1 - p0).cross(r0 - p0).normalized();
  std::vector<std::vector<Vec3>> chimney_holes;
  std::vector<Ring> chimney_footprints;
  const int nch = rng.uniform_int(0, 2);
  for (int k = 0; k < nch; ++k) {
    const double cw = rng.uniform(0.6, 1.0), cd = rng.uniform(0.6, 1.0);
    const double cx = hx + 1.0 + (L - 2 * hx - 2.0 - cw) * (k + rng.uniform(0.2, 0.8)) / std::max(1, nch);
    const double cy = rng.uniform(W * 0.15, W * 0.5 - cd - 0.3);
    if (cx < hx + 0.3 || cx + cw > L - hx - 0.3 || cy < 0.3) continue;
    // note: on a short slope (hip roofs) the two chimneys' x ranges can overlap. Overlapping holes
    // would be wrong twice over: the roof's even-odd inside test puts roof triangles back over their
    // intersection (wound against the chimney walls, see test_synth_hard), and the walls cross. Such
    // a chimney is skipped (after its random draws, so the rest of the building is unchanged).
    bool clear = true;
    for (const Ring& o : chimney_footprints)
      clear = clear && (cx > o[2].x() + 0.3 || cx + cw < o[0].x() - 0.3 || cy > o[2].y() + 0.3 || cy + cd < o[0].y() - 0.3);
    if (!clear) continue;
    auto zr = [&](double y) { return H + rh * y / (W / 2); };
    const double top = zr(cy + cd) + rng.uniform(0.6, 1.2);
    const Ring fp = rect(cx, cy, cx + cw, cy + cd);
    chimney_footprints.push_back(fp);
    std::vector<Vec3> hole;
    for (size_t i = 0; i < 4; ++i) {
      const Vec2& a = fp[i];
      const Vec2& c = fp[(i + 1) % 4];
      hole.emplace_back(a.x(), a.y(), zr(a.y()));
      const double L4 = (c - a).norm();
      b.wall(a, c, 0, {{0, zr(a.y())}, {L4, zr(c.y())}, {L4, top}, {0, top}}, {}, SemanticClass::Detail);
    }
    b.poly_new(SemanticClass::Detail, lift(fp, top), Vec3::UnitZ());
    chimney_holes.push_back(hole);
  }
  const int s1 = b.plane(SemanticClass::Roof, n1, p0);
  b.poly({p0, p1, r1, r0}, n1, s1, chimney_holes);
  const Vec3 n2 = (p3 - p2).cross(r1 - p2).normalized();
  b.poly_new(SemanticClass::Roof, {p2, p3, r0, r1}, n2);
  if (hip) {
    b.poly_new(SemanticClass::Roof, {p1, p2, r1}, (p2 - p1).cross(r1 - p1));
    b.poly_new(SemanticClass::Roof, {p3, p0, r0}, (p0 - p3).cross(r0 - p3));
  }
  b.set_bbox(0, 0, L, W, H + rh + 1.5);
}

Shape residential(Rng& rng, double scale) {
  Builder b(rng);
  const double L = rng.uniform(10, 18) * scale, W = rng.uniform(8, 11) * std::sqrt(scale);
  const double fh = rng.uniform(2.7, 3.1);
  const int floors = rng.uniform_int(2, 4);
  pitched_house(b, rng, L, W, floors * fh + 0.3, fh, rng.chance(0.45));
  std::vector<std::vector<Vec3>> fps = {lift(rect(0, 0, L, W), 0)};
  if (rng.chance(0.35)) fps.push_back(b.cylinder({-2.2, W * 0.5}, 1.6, floors * fh + 1.5));
  b.ground(fps, {});
  b.shape.archetype = "residential";
  return b.shape;
}

Shape factory(Rng& rng, double scale) {
  Builder b(rng);
  const double L = rng.uniform(40, 80) * scale, W = rng.uniform(18, 32) * std::sqrt(scale);
  const double H = rng.uniform(8, 13);
  auto band = [&](double len) {  // a strip of large windows high on the long walls
    std::vector<Opening> o;
    const double w = rng.uniform(3.0, 5.0), gap = rng.uniform(1.5, 3.0), v0 = H - rng.uniform(3.5, 4.5);
    for (double u = 2.0; u + w < len - 2.0; u += w + gap) o.push_back({u, v0, u + w, v0 + 2.0, false, 0.15});
    return o;
  };
  auto doors = [&](double len) {
    std::vector<Opening> o;
    const double dw = rng.uniform(4, 6);
    if (len > dw + 4) o.push_back({len / 2 - dw / 2, 0.4, len / 2 + dw / 2, 0.4 + rng.uniform(4, 5), false, 0.35});
    return o;
  };
  std::vector<std::vector<Vec3>> fps = {lift(rect(0, 0, L, W), 0)};
  if (rng.chance(0.5)) {
    // sawtooth roof: teeth along x, each a slope rising to +th and a vertical glazing face; the
    // last glazing face is the top of the end wall at x = L
    const int n = std::max(3, static_cast<int>(L / rng.uniform(7, 11)));
    const double t = L / n, th = rng.uniform(2.5, 4.0);
    std::vector<Vec2> side = {{0, 0}, {L, 0}, {L, H + th}};  // wall y = 0, u = x
    for (int i = n - 1; i >= 1; --i) {
      side.emplace_back(i * t, H);
      side.emplace_back(i * t, H + th);
    }
    side.emplace_back(0, H);
    b.wall({0, 0}, {L, 0}, 0, side, band(L));
    std::vector<Vec2> back = {{0, 0}, {L, 0}, {L, H}};  // wall y = W runs x = L..0, u = L - x
    for (int i = 1; i <= n - 1; ++i) {
      back.emplace_back(L - i * t, H + th);
      back.emplace_back(L - i * t, H);
    }
    back.emplace_back(0, H + th);
    b.wall({L, W}, {0, W}, 0, back, band(L));
    b.wall({L, 0}, {L, W}, 0, {{0, 0}, {W, 0}, {W, H + th}, {0, H + th}}, doors(W));
    b.wall({0, W}, {0, 0}, 0, {{0, 0}, {W, 0}, {W, H}, {0, H}}, doors(W));
    for (int i = 0; i < n; ++i) {
      const double x0 = i * t, x1 = (i + 1) * t;
      const Vec3 a(x0, 0, H), c(x1, 0, H + th), d(x1, W, H + th), e(x0, W, H);
      b.poly_new(SemanticClass::Roof, {a, c, d, e}, (c - a).cross(e - a));
      if (i + 1 < n)
        b.poly_new(SemanticClass::Roof, {Vec3(x1, 0, H), Vec3(x1, W, H), d, c}, Vec3::UnitX());
    }
    b.set_bbox(0, 0, L, W, H + th);
  } else {
    const double ph = rng.chance(0.6) ? rng.uniform(0.6, 1.2) : 0.0;
    b.wall({0, 0}, {L, 0}, 0, {{0, 0}, {L, 0}, {L, H + ph}, {0, H + ph}}, band(L));
    b.wall({L, W}, {0, W}, 0, {{0, 0}, {L, 0}, {L, H + ph}, {0, H + ph}}, band(L));
    b.wall({L, 0}, {L, W}, 0, {{0, 0}, {W, 0}, {W, H + ph}, {0, H + ph}}, doors(W));
    b.wall({0, W}, {0, 0}, 0, {{0, 0}, {W, 0}, {W, H + ph}, {0, H + ph}}, doors(W));
    auto boxes = b.roof_boxes(1.0, 1.0, L - 1.0, W - 1.0, H, rng.uniform_int(2, 6), {});
    b.flat_roof({rect(0, 0, L, W)}, H, ph, boxes);
    b.set_bbox(0, 0, L, W, H + ph + 2.5);
  }
  if (rng.chance(0.4)) {
    const double r = rng.uniform(2.5, 4.0);
    fps.push_back(b.cylinder({L * rng.uniform(0.2, 0.8), -r - 1.0}, r, H + rng.uniform(2, 8)));
  }
  b.ground(fps, {});
  b.shape.archetype = "factory";
  return b.shape;
}

Shape hotel(Rng& rng, double scale) {
  Builder b(rng);
  const double Lp = rng.uniform(30, 46) * std::sqrt(scale), Wp = rng.uniform(20, 30) * std::sqrt(scale);
  const double hp = rng.uniform(6, 9);
  const double Lt = rng.uniform(std::min(15.0, Lp - 10), std::min(24.0, Lp - 8));
  const double Wt = rng.uniform(std::min(12.0, Wp - 8), std::min(17.0, Wp - 6));
  const double ht = hp + rng.uniform(22, 40) * std::sqrt(scale);
  const double tx = rng.uniform(3, Lp - Lt - 3), ty = rng.uniform(3, Wp - Wt - 3);
  const double fh = rng.uniform(3.0, 3.4);
  const double pp = rng.uniform(0.6, 1.1);
  // podium with a band of shop windows
  const Ring podium = rect(0, 0, Lp, Wp);
  for (size_t i = 0; i < 4; ++i) {
    const Vec2& a = podium[i];
    const Vec2& c = podium[(i + 1) % 4];
    const double L = (c - a).norm();
    std::vector<Opening> o;
    for (double u = 1.5; u + 4.0 < L - 1.0; u += 5.0) o.push_back({u, 0.5, u + 3.5, 3.5, false, 0.25});
    b.wall(a, c, 0, {{0, 0}, {L, 0}, {L, hp + pp}, {0, hp + pp}}, o);
  }
  const Ring tower = rect(tx, ty, tx + Lt, ty + Wt);
  // tower walls with a window grid, optional setback crown
  const bool setback = rng.chance(0.5);
  const double sb = rng.uniform(2.0, 3.0), hs = rng.uniform(6, 12);
  const double tp = setback ? 0.0 : rng.uniform(0.8, 1.4);
  for (size_t i = 0; i < 4; ++i) {
    const Vec2& a = tower[i];
    const Vec2& c = tower[(i + 1) % 4];
    const double L = (c - a).norm();
    auto w = b.windows(L, ht - hp, fh, 1.0, i == 0);
    b.wall(a, c, hp, {{0, 0}, {L, 0}, {L, ht - hp + tp}, {0, ht - hp + tp}}, w);
  }
  std::vector<std::vector<Vec3>> podium_holes = {lift(tower, hp)};
  std::vector<Eigen::Vector4d> keep = {{tx - 1, ty - 1, tx + Lt + 1, ty + Wt + 1}};
  auto boxes = b.roof_boxes(1, 1, Lp - 1, Wp - 1, hp, rng.uniform_int(1, 4), keep);
  for (auto& h : boxes) podium_holes.push_back(h);
  b.flat_roof({podium}, hp, pp, podium_holes);
  double top = ht + tp;
  if (setback) {
    const Ring crown = inset(tower, sb);
    b.ring_walls(crown, ht, ht + hs + 1.0, fh, 0.8, true);
    b.flat_roof({tower}, ht, 0, {lift(crown, ht)});
    b.flat_roof({crown}, ht + hs, 1.0, {});
    top = ht + hs + 1.0;
  } else {
    auto tb = b.roof_boxes(tx + 1, ty + 1, tx + Lt - 1, ty + Wt - 1, ht, rng.uniform_int(1, 3), {});
    b.flat_roof({tower}, ht, tp, tb);
  }
  b.set_bbox(0, 0, Lp, Wp, top + 2);
  std::vector<std::vector<Vec3>> fps = {lift(podium, 0)};
  if (rng.chance(0.5)) {
    const double r = rng.uniform(2.0, 3.0);
    fps.push_back(b.cylinder({Lp + r + 0.8, Wp * rng.uniform(0.3, 0.7)}, r, hp + rng.uniform(3, 8)));
  }
  b.ground(fps, {});
  b.shape.archetype = "hotel";
  return b.shape;
}

Shape lshape(Rng& rng, double scale) {
  Builder b(rng);
  const double A = rng.uniform(22, 36) * std::sqrt(scale), B = rng.uniform(18, 30) * std::sqrt(scale);
  const double w1 = rng.uniform(9, 13), w2 = rng.uniform(9, 13);
  const double fh = rng.uniform(2.9, 3.3);
  const double H = rng.uniform_int(3, 6) * fh + 0.5;
  const double ph = rng.uniform(0.6, 1.2);
  const Ring L = {{0, 0}, {A, 0}, {A, w1}, {w2, w1}, {w2, B}, {0, B}};
  b.ring_walls(L, 0, H + ph, fh, 0.9, true);
  auto boxes = b.roof_boxes(1, 1, A - 1, w1 - 1, H, rng.uniform_int(1, 3), {});
  auto more = b.roof_boxes(1, w1 + 1, w2 - 1, B - 1, H, rng.uniform_int(0, 2), {});
  for (auto& h : more) boxes.push_back(h);
  b.flat_roof({L}, H, ph, boxes);
  b.set_bbox(0, 0, A, B, H + ph + 2.5);
  std::vector<std::vector<Vec3>> fps = {lift(L, 0)};
  if (rng.chance(0.4)) fps.push_back(b.cylinder({w2 + 3.5, w1 + 3.5}, rng.uniform(1.8, 2.6), H + rng.uniform(2, 4)));
  b.ground(fps, {});
  b.shape.archetype = "lshape";
  return b.shape;
}

Shape courtyard(Rng& rng, double scale) {
  Builder b(rng);
  const double A = rng.uniform(30, 46) * std::sqrt(scale), B = rng.uniform(28, 42) * std::sqrt(scale);
  const double d = rng.uniform(9, 12);
  const double fh = rng.uniform(2.9, 3.3);
  const double H = rng.uniform_int(3, 5) * fh + 0.4;
  const bool parapet = rng.chance(0.5);
  const double ph = parapet ? rng.uniform(0.6, 1.0) : 0.0;
  const Ring outer = rect(0, 0, A, B);
  const Ring court = {{d, d}, {d, B - d}, {A - d, B - d}, {A - d, d}};  // clockwise: building on the left
  b.ring_walls(outer, 0, H + ph, fh, 0.9, true);
  b.ring_walls(court, 0, H + ph, fh, 0.9, true);
  auto boxes = b.roof_boxes(1, 1, A - 1, d - 1, H, rng.uniform_int(1, 3), {});
  b.flat_roof({outer, court}, H, ph, boxes);
  b.set_bbox(0, 0, A, B, H + ph + 2.5);
  std::vector<std::vector<Vec3>> fps = {lift(outer, 0)};
  std::reverse(fps[0].begin(), fps[0].end());
  b.ground(fps, {court});
  b.shape.archetype = "courtyard";
  return b.shape;
}

}  // namespace

Shape build_shape(Archetype archetype, Rng& rng, double scale) {
  switch (archetype) {
    case Archetype::Residential: return residential(rng, scale);
    case Archetype::Factory: return factory(rng, scale);
    case Archetype::Hotel: return hotel(rng, scale);
    case Archetype::LShape: return lshape(rng, scale);
    case Archetype::Courtyard: return courtyard(rng, scale);
    case Archetype::Mixed: break;
  }
  throw std::invalid_argument("synth: build_shape needs a concrete archetype");
}

}  // namespace texdefrag::synth::detail
