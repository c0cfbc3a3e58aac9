// Cameras of an oblique aerial flight and per-face view selection imitating photogrammetry
// texturing (e.g. Waechter et al. 2014, "Let there be color!"; ContextCapture behaves alike): each
// face takes the camera with the best score (viewing angle and distance, visibility required),
// perturbed by noise, then a few majority-vote passes over face neighbours. With the default noise
// the labels form small irregular patches whose borders ignore plane boundaries, as in real tiles.
#include "internal.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace texdefrag::synth::detail {
namespace {

Camera look(const std::string& kind, const Vec3& pos, const Vec3& target, const Vec3& right_hint, double f, Rng& rng) {
  Camera c;
  c.kind = kind;
  c.position = pos;
  const Vec3 fwd = (target - pos).normalized();
  Vec3 right = fwd.cross(Vec3::UnitZ());
  if (right.norm() < 1e-6) right = right_hint - right_hint.dot(fwd) * fwd;
  right.normalize();
  const Vec3 down = fwd.cross(right);
  c.rotation = {right, down, fwd};
  c.focal_px = f;
  c.width = 6000;
  c.height = 4000;
  c.exposure = rng.uniform(0.82, 1.18);
  c.colour_gain = Vec3(1 + 0.05 * rng.normal(), 1 + 0.05 * rng.normal(), 1 + 0.05 * rng.normal());
  return c;
}

/// Maximum building height per 0.5 m ground cell, for a coarse occlusion test.
struct HeightField {
  double x0 = 0, y0 = 0, cell = 0.5;
  int nx = 0, ny = 0;
  double zmax = 0;
  std::vector<float> h;
  float at(double x, double y) const {
    const int i = static_cast<int>(std::floor((x - x0) / cell)), j = static_cast<int>(std::floor((y - y0) / cell));
    if (i < 0 || j < 0 || i >= nx || j >= ny) return -1e9f;
    return h[static_cast<size_t>(j) * static_cast<size_t>(nx) + static_cast<size_t>(i)];
  }
};

HeightField height_field(const RawMesh& m, const Shape& shape) {
  HeightField hf;
  Vec3 lo = m.positions.empty() ? Vec3::Zero() : m.positions[0], hi = lo;
  for (const Vec3& p : m.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  hf.x0 = lo.x();
  hf.y0 = lo.y();
  hf.nx = static_cast<int>((hi.x() - lo.x()) / hf.cell) + 1;
  hf.ny = static_cast<int>((hi.y() - lo.y()) / hf.cell) + 1;
  hf.h.assign(static_cast<size_t>(hf.nx) * static_cast<size_t>(hf.ny), -1e9f);
  for (size_t f = 0; f < m.tris.size(); ++f) {
    if (shape.planes[static_cast<size_t>(m.face_plane[f])].semantic == SemanticClass::Ground) continue;
    Vec3 a = m.positions[static_cast<size_t>(m.tris[f][0])], b = a;
    for (int k = 1; k < 3; ++k) {
      a = a.cwiseMin(m.positions[static_cast<size_t>(m.tris[f][static_cast<size_t>(k)])]);
      b = b.cwiseMax(m.positions[static_cast<size_t>(m.tris[f][static_cast<size_t>(k)])]);
    }
    hf.zmax = std::max(hf.zmax, b.z());
    const int i0 = static_cast<int>((a.x() - hf.x0) / hf.cell), i1 = static_cast<int>((b.x() - hf.x0) / hf.cell);
    const int j0 = static_cast<int>((a.y() - hf.y0) / hf.cell), j1 = static_cast<int>((b.y() - hf.y0) / hf.cell);
    for (int j = std::max(0, j0); j <= std::min(hf.ny - 1, j1); ++j)
      for (int i = std::max(0, i0); i <= std::min(hf.nx - 1, i1); ++i) {
        float& c = hf.h[static_cast<size_t>(j) * static_cast<size_t>(hf.nx) + static_cast<size_t>(i)];
        c = std::max(c, static_cast<float>(b.z()));
      }
  }
  return hf;
}

/// True when the segment from x (lifted off the surface along n) towards the camera passes below
/// the height field (ignoring the first metre, which is the face's own wall/roof cell).
bool occluded(const HeightField& hf, const Vec3& x, const Vec3& n, const Vec3& cam) {
  const Vec3 start = x + 0.25 * n;
  const Vec3 d = (cam - start).normalized();
  if (d.z() <= 0) return false;
  const double step = 0.6;
  for (double t = 1.0;; t += step) {
    const Vec3 p = start + t * d;
    if (p.z() > hf.zmax) return false;
    if (p.z() < hf.at(p.x(), p.y()) - 0.3) return true;
  }
}

/// Per face of m, per edge k (from corner k to k + 1): a face sharing that edge (the first other
/// one listed), or -1.
std::vector<std::array<int, 3>> face_neighbours(const RawMesh& m) {
  const size_t F = m.tris.size();
  std::unordered_map<uint64_t, std::vector<int>> edge_faces;
  edge_faces.reserve(F * 2);
  for (size_t f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.tris[f][static_cast<size_t>(k)], b = m.tris[f][static_cast<size_t>((k + 1) % 3)];
      const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint64_t>(std::max(a, b));
      edge_faces[key].push_back(static_cast<int>(f));
    }
  std::vector<std::array<int, 3>> nbr(F, {-1, -1, -1});
  for (size_t f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.tris[f][static_cast<size_t>(k)], b = m.tris[f][static_cast<size_t>((k + 1) % 3)];
      const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint64_t>(std::max(a, b));
      for (int g : edge_faces[key])
        if (g != static_cast<int>(f)) {
          nbr[f][static_cast<size_t>(k)] = g;
          break;
        }
    }
  return nbr;
}

/// One pass of charts across planes: a face next to a face of another plane takes that neighbour's
/// view (the first one, by edge) when the face sees it (valid, F x C) and cross_rng.chance(cross_plane).
void cross_plane_views(const RawMesh& m, const std::vector<std::array<int, 3>>& nbr, const std::vector<uint8_t>& valid,
                       size_t C, double cross_plane, Rng& cross_rng, std::vector<int>& view) {
  const size_t F = m.tris.size();
  std::vector<int> next = view;
  for (size_t f = 0; f < F; ++f)
    for (int g : nbr[f]) {
      if (g < 0 || m.face_plane[static_cast<size_t>(g)] == m.face_plane[f]) continue;
      const int l = view[static_cast<size_t>(g)];
      if (l != view[f] && valid[f * C + static_cast<size_t>(l)] && cross_rng.chance(cross_plane)) {
        next[f] = l;
        break;
      }
    }
  view.swap(next);
}

/// `passes` majority-vote passes: a face takes the view of two or more of its neighbours when it
/// sees it (valid, F x C); every pass reads the views of the one before.
void majority_passes(const std::vector<std::array<int, 3>>& nbr, const std::vector<uint8_t>& valid, size_t C, int passes,
                     std::vector<int>& view) {
  const size_t F = nbr.size();
  for (int pass = 0; pass < passes; ++pass) {
    std::vector<int> next = view;
    for (size_t f = 0; f < F; ++f) {
      const auto& nb = nbr[f];
      for (int i = 0; i < 3; ++i) {
        if (nb[static_cast<size_t>(i)] < 0) continue;
        const int l = view[static_cast<size_t>(nb[static_cast<size_t>(i)])];
        if (l == view[f]) continue;
        int count = 0;
        for (int j = 0; j < 3; ++j)
          if (nb[static_cast<size_t>(j)] >= 0 && view[static_cast<size_t>(nb[static_cast<size_t>(j)])] == l) ++count;
        if (count >= 2 && valid[f * C + static_cast<size_t>(l)]) {
          next[f] = l;
          break;
        }
      }
    }
    view.swap(next);
  }
}

}  // namespace

bool project(const Camera& c, const Vec3& p, Vec2& pixel) {
  const Vec3 d = p - c.position;
  const double qz = c.rotation[2].dot(d);
  if (qz <= 1e-9) return false;
  pixel = Vec2(c.width * 0.5 + c.focal_px * c.rotation[0].dot(d) / qz, c.height * 0.5 + c.focal_px * c.rotation[1].dot(d) / qz);
  return true;
}

std::vector<Camera> make_cameras(const Shape& shape, Rng& rng) {
  const Vec3 lo = shape.bbox_min, hi = shape.bbox_max;
  const Vec3 centre(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0);
  const double R = 0.5 * Vec2(hi.x() - lo.x(), hi.y() - lo.y()).norm() + 12.0;
  const double altitude = hi.z() + rng.uniform(110, 170);
  // the whole patch (2R across) fills about 60% of the 6000-pixel image width from nadir
  const double f = 6000 * 0.6 * altitude / (2 * R);
  std::vector<Camera> cams;
  const double yaw = rng.uniform(0, 6.283185307179586);
  const Vec3 along(std::cos(yaw), std::sin(yaw), 0), across(-std::sin(yaw), std::cos(yaw), 0);
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j) {
      const Vec3 pos = centre + (0.35 * R * i + rng.uniform(-2, 2)) * along + (0.35 * R * j + rng.uniform(-2, 2)) * across +
                       Vec3(0, 0, altitude + rng.uniform(-3, 3));
      cams.push_back(look("nadir", pos, pos - Vec3(0, 0, 1), along, f, rng));
    }
  const char* names[4] = {"oblique_n", "oblique_e", "oblique_s", "oblique_w"};
  for (int k = 0; k < 4; ++k) {
    const double a = yaw + k * 1.5707963267948966;
    const Vec3 look_dir(std::cos(a), std::sin(a), 0);  // horizontal direction the camera looks
    const Vec3 side(-look_dir.y(), look_dir.x(), 0);
    const double tilt = rng.uniform(40, 50) * 3.141592653589793 / 180;
    const double h = altitude - hi.z() * 0.4;
    for (int i = -1; i <= 1; ++i) {
      const Vec3 aim = centre + Vec3(0, 0, hi.z() * 0.4) + (0.45 * R * i) * side;
      const Vec3 pos = aim - look_dir * (h / std::tan(tilt)) + Vec3(0, 0, h) + rng.uniform(-3, 3) * side;
      cams.push_back(look(names[k], pos, aim, side, f * 1.15, rng));
    }
  }
  return cams;
}

std::vector<int> select_views(const RawMesh& m, const Shape& shape, const std::vector<Camera>& cams, double noise,
                              double noise_iid, int passes, Rng& rng, double cross_plane, Rng& cross_rng) {
  const size_t F = m.tris.size(), C = cams.size();
  const HeightField hf = height_field(m, shape);
  std::vector<uint8_t> valid(F * C, 0);
  std::vector<int> view(F, 0);
  std::vector<uint64_t> salt(C);
  for (uint64_t& v : salt) v = rng.next();
  for (size_t f = 0; f < F; ++f) {
    const Vec3& a = m.positions[static_cast<size_t>(m.tris[f][0])];
    const Vec3& b = m.positions[static_cast<size_t>(m.tris[f][1])];
    const Vec3& c = m.positions[static_cast<size_t>(m.tris[f][2])];
    const Vec3 x = (a + b + c) / 3.0;
    Vec3 n = (b - a).cross(c - a);
    n = n.norm() > 0 ? n.normalized() : Vec3::UnitZ();
    double best = -1e300, fallback = -1e300;
    int best_c = -1, fallback_c = 0;
    for (size_t k = 0; k < C; ++k) {
      const Vec3 d = cams[k].position - x;
      const double dist = d.norm();
      const double cosang = n.dot(d) / dist;
      const double eps = rng.normal();  // drawn for every pair: the stream does not depend on tests
      Vec2 px;
      if (!project(cams[k], x, px)) continue;
      if (cosang > fallback) {
        fallback = cosang;
        fallback_c = static_cast<int>(k);
      }
      if (cosang < 0.08) continue;
      if (px.x() < 0 || px.y() < 0 || px.x() > cams[k].width || px.y() > cams[k].height) continue;
      if (occluded(hf, x, n, cams[k].position)) continue;
      valid[f * C + k] = 1;
      // note: smooth noise (value noise, 2.5 m cells, about unit spread) makes patches with
      // jagged borders; the i.i.d. part makes the scattered single triangles real tiles have.
      const double field = (value_noise(x, 2.5, salt[k]) - 0.5) * 4.0;
      const double s = std::log(cosang) - std::log(dist) + noise * field + noise_iid * eps;
      if (s > best) {
        best = s;
        best_c = static_cast<int>(k);
      }
    }
    view[f] = best_c >= 0 ? best_c : fallback_c;
    if (best_c < 0) valid[f * C + static_cast<size_t>(fallback_c)] = 1;
  }
  // face neighbours across shared edges (any number of faces per edge)
  const std::vector<std::array<int, 3>> nbr = face_neighbours(m);
  // Charts across planes: a face next to another plane takes that neighbour's view when it sees it.
  if (cross_plane > 0) cross_plane_views(m, nbr, valid, C, cross_plane, cross_rng, view);
  majority_passes(nbr, valid, C, passes, view);
  return view;
}

}  // namespace texdefrag::synth::detail
