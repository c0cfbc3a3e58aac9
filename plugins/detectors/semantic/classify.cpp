#include "semantic/classify.h"

#include "common/normals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

namespace texdefrag::detectors::semantic {

const char* class_name(FaceClass c) {
  switch (c) {
    case FaceClass::Ground: return "ground";
    case FaceClass::Vegetation: return "vegetation";
    case FaceClass::Building: return "building";
    case FaceClass::Other: return "other";
  }
  return "?";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Calls fn(g) for every face g sharing a welded edge with face f (g != f).
template <class F>
void for_each_neighbour(const Topology& topo, size_t f, F&& fn) {
  for (int e : topo.face_edge[f]) {
    const Edge& ed = topo.edges[static_cast<size_t>(e)];
    for (int i = 0; i < ed.num_faces; ++i) {
      const int g = topo.edge_faces[static_cast<size_t>(ed.first_incidence + i)].face;
      if (g != static_cast<int>(f)) fn(g);
    }
  }
}

Vec3 centroid(const TexturedMesh& m, size_t f) {
  return (m.corner_position(f, 0) + m.corner_position(f, 1) + m.corner_position(f, 2)) / 3.0;
}

/// A regular grid over the plane perpendicular to `up`.
struct Grid {
  Vec3 e1, e2;
  double s0 = 0, t0 = 0, cell = 1;
  int nx = 1, ny = 1;
  std::vector<double> value;

  double& at(int x, int y) { return value[static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)]; }
  double at(int x, int y) const { return value[static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)]; }
};

Grid make_grid(const std::vector<Vec3>& pts, const Vec3& up, double cell) {
  Grid g;
  g.e1 = up.unitOrthogonal();
  g.e2 = up.cross(g.e1);
  g.cell = cell;
  double s1 = -kInf, t1 = -kInf;
  g.s0 = g.t0 = kInf;
  for (const Vec3& p : pts) {
    g.s0 = std::min(g.s0, p.dot(g.e1)), s1 = std::max(s1, p.dot(g.e1));
    g.t0 = std::min(g.t0, p.dot(g.e2)), t1 = std::max(t1, p.dot(g.e2));
  }
  if (pts.empty()) g.s0 = g.t0 = s1 = t1 = 0;
  g.nx = std::max(1, static_cast<int>(std::floor((s1 - g.s0) / cell)) + 1);
  g.ny = std::max(1, static_cast<int>(std::floor((t1 - g.t0) / cell)) + 1);
  g.value.assign(static_cast<size_t>(g.nx) * static_cast<size_t>(g.ny), kInf);
  return g;
}

std::pair<int, int> cell_of(const Grid& g, const Vec3& p) {
  const int x = std::clamp(static_cast<int>((p.dot(g.e1) - g.s0) / g.cell), 0, g.nx - 1);
  const int y = std::clamp(static_cast<int>((p.dot(g.e2) - g.t0) / g.cell), 0, g.ny - 1);
  return {x, y};
}

/// Per cell, the 10th percentile of the heights of the points in it (robust to a few spikes
/// below the ground); +inf for empty cells.
void fill_low_points(Grid& g, const std::vector<Vec3>& pts, const Vec3& up) {
  std::vector<std::vector<double>> cells(g.value.size());
  for (const Vec3& p : pts) {
    const auto [x, y] = cell_of(g, p);
    cells[static_cast<size_t>(y) * static_cast<size_t>(g.nx) + static_cast<size_t>(x)].push_back(p.dot(up));
  }
  for (size_t i = 0; i < cells.size(); ++i) {
    auto& h = cells[i];
    if (h.empty()) continue;
    const size_t k = h.size() / 10;
    std::nth_element(h.begin(), h.begin() + static_cast<std::ptrdiff_t>(k), h.end());
    g.value[i] = h[k];
  }
}

/// Empty cells take the mean of their filled 4-neighbours, front by front (nearest filled cells).
void fill_empty_cells(Grid& g) {
  std::vector<size_t> front;
  for (size_t i = 0; i < g.value.size(); ++i)
    if (g.value[i] == kInf) front.push_back(i);
  while (!front.empty()) {
    std::vector<std::pair<size_t, double>> set;
    std::vector<size_t> next;
    for (size_t i : front) {
      const int x = static_cast<int>(i % static_cast<size_t>(g.nx)), y = static_cast<int>(i / static_cast<size_t>(g.nx));
      double sum = 0;
      int n = 0;
      const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        const int u = x + dx[k], v = y + dy[k];
        if (u < 0 || v < 0 || u >= g.nx || v >= g.ny || g.at(u, v) == kInf) continue;
        sum += g.at(u, v), ++n;
      }
      if (n) set.emplace_back(i, sum / n);
      else next.push_back(i);
    }
    if (set.empty()) break;  // no filled cell at all
    for (const auto& [i, v] : set) g.value[i] = v;
    front.swap(next);
  }
  for (double& v : g.value)
    if (v == kInf) v = 0;
}

/// Separable min (erode) or max (dilate) filter with a square window of 2r+1 cells.
void window_filter(Grid& g, int r, bool take_min) {
  auto pick = [take_min](double a, double b) { return take_min ? std::min(a, b) : std::max(a, b); };
  for (int pass = 0; pass < 2; ++pass) {
    Grid src = g;
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x) {
        double v = src.at(x, y);
        for (int d = -r; d <= r; ++d) {
          const int u = pass == 0 ? x + d : x, w = pass == 0 ? y : y + d;
          if (u >= 0 && w >= 0 && u < g.nx && w < g.ny) v = pick(v, src.at(u, w));
        }
        g.at(x, y) = v;
      }
  }
}

/// Bilinear interpolation of the grid at cell-centre samples.
double sample(const Grid& g, const Vec3& p) {
  const double fx = std::clamp((p.dot(g.e1) - g.s0) / g.cell - 0.5, 0.0, static_cast<double>(g.nx - 1));
  const double fy = std::clamp((p.dot(g.e2) - g.t0) / g.cell - 0.5, 0.0, static_cast<double>(g.ny - 1));
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  const int x1 = std::min(x0 + 1, g.nx - 1), y1 = std::min(y0 + 1, g.ny - 1);
  const double a = fx - x0, b = fy - y0;
  return (1 - a) * (1 - b) * g.at(x0, y0) + a * (1 - b) * g.at(x1, y0) + (1 - a) * b * g.at(x0, y1) + a * b * g.at(x1, y1);
}

/// The opened ground surface: robust lowest points per cell, holes filled, then an opening wider
/// than the buildings.
Grid opened_ground(const std::vector<Vec3>& c, const ClassifyOptions& o) {
  Grid g = make_grid(c, o.up, o.ground_cell);
  fill_low_points(g, c, o.up);
  fill_empty_cells(g);
  const int r = std::max(1, static_cast<int>(std::lround(0.5 * o.ground_window / o.ground_cell)));
  window_filter(g, r, true);
  window_filter(g, r, false);
  return g;
}

/// Height of every face centroid above the ground. The opening lies below the true ground where
/// the data has spikes under it, so it is refined once: in each cell holding near-horizontal
/// faces less than 2 ground_height above the opened surface, the ground is their median height.
std::vector<double> heights_above_ground(const std::vector<Vec3>& c, const std::vector<Vec3>& normals,
                                         const ClassifyOptions& o) {
  Grid g = opened_ground(c, o);
  const double cos_ground = std::cos(o.ground_slope_deg * M_PI / 180.0);
  std::vector<std::vector<double>> near(g.value.size());
  for (size_t f = 0; f < c.size(); ++f) {
    const double h = c[f].dot(o.up) - sample(g, c[f]);
    if (h < 2 * o.ground_height && normals[f].dot(o.up) >= cos_ground) {
      const auto [x, y] = cell_of(g, c[f]);
      near[static_cast<size_t>(y) * static_cast<size_t>(g.nx) + static_cast<size_t>(x)].push_back(c[f].dot(o.up));
    }
  }
  Grid refined = g;
  for (size_t i = 0; i < near.size(); ++i) {
    auto& v = near[i];
    if (v.size() < 3) continue;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    refined.value[i] = v[v.size() / 2];
  }
  std::vector<double> h(c.size());
  for (size_t f = 0; f < c.size(); ++f) h[f] = c[f].dot(o.up) - sample(refined, c[f]);
  return h;
}

/// The face's k-ring (edge neighbours, manifold or not), the face first.
void k_ring(const Topology& topo, size_t f, int rings, std::vector<int>& stamp, std::vector<int>& patch) {
  patch.assign(1, static_cast<int>(f));
  stamp[f] = static_cast<int>(f);
  size_t begin = 0;
  for (int ring = 0; ring < rings; ++ring) {
    const size_t end = patch.size();
    for (size_t i = begin; i < end; ++i)
      for_each_neighbour(topo, static_cast<size_t>(patch[i]), [&](int g) {
        if (stamp[static_cast<size_t>(g)] != static_cast<int>(f)) stamp[static_cast<size_t>(g)] = static_cast<int>(f), patch.push_back(g);
      });
    begin = end;
  }
}

/// Normal scatter and coherence of every face's k-ring patch. area: 3D area per face.
void patch_features(const std::vector<double>& area, const Topology& topo, const std::vector<Vec3>& normals, int rings,
                    Classification& out) {
  const size_t nf = area.size();
  out.scatter.assign(nf, 0);
  out.coherence.assign(nf, 1);
  const double cos_agree = std::cos(20.0 * M_PI / 180.0);
  std::vector<int> stamp(nf, -1), patch;
  for (size_t f = 0; f < nf; ++f) {
    k_ring(topo, f, rings, stamp, patch);
    Vec3 nsum = Vec3::Zero();
    double total = 0, agree = 0;
    for (int g : patch) {
      const size_t gi = static_cast<size_t>(g);
      nsum += area[gi] * normals[gi];
      total += area[gi];
      if (normals[gi].dot(normals[f]) >= cos_agree) agree += area[gi];
    }
    if (total <= 0) continue;
    out.scatter[f] = std::clamp(1.0 - nsum.norm() / total, 0.0, 1.0);
    out.coherence[f] = agree / total;
  }
}

/// Ground / vegetation / building candidate (Other until the component test) per face.
std::vector<int> initial_classes(const std::vector<Vec3>& normals, const Classification& c, const ClassifyOptions& o,
                                 std::vector<uint8_t>& candidate) {
  const double cos_ground = std::cos(o.ground_slope_deg * M_PI / 180.0);
  std::vector<int> cls(normals.size(), static_cast<int>(FaceClass::Other));
  candidate.assign(normals.size(), 0);
  for (size_t f = 0; f < normals.size(); ++f) {
    const bool rough = c.scatter[f] > o.vegetation_scatter && c.coherence[f] < o.vegetation_coherence;
    const bool low = c.height[f] < o.ground_height;
    if (low && normals[f].dot(o.up) >= cos_ground && !rough) cls[f] = static_cast<int>(FaceClass::Ground);
    else if (rough && !low) cls[f] = static_cast<int>(FaceClass::Vegetation);
    else if (!rough) candidate[f] = 1;
  }
  return cls;
}

/// Area fraction of every component lying in large planar patches. Patches are grown inside each
/// component from seeds in face order: a face joins its neighbour's patch when its filtered normal is
/// within plane_angle_deg of the patch seed's (the seed, not the neighbour, so a curved surface does
/// not drift into one patch); patches of at least plane_min_area count. face_area: 3D area per face.
std::vector<double> planar_fractions(const std::vector<double>& face_area, const Topology& topo, const std::vector<int>& comp,
                                     int n, const std::vector<Vec3>& normals, const ClassifyOptions& o) {
  const double cos_plane = std::cos(o.plane_angle_deg * M_PI / 180.0);
  std::vector<double> planar(static_cast<size_t>(n), 0), total(static_cast<size_t>(n), 0);
  std::vector<uint8_t> done(comp.size(), 0);
  std::vector<int> patch;
  for (size_t s = 0; s < comp.size(); ++s) {
    if (comp[s] < 0 || done[s]) continue;
    done[s] = 1;
    patch.assign(1, static_cast<int>(s));
    double area = 0;
    for (size_t i = 0; i < patch.size(); ++i) {
      const size_t f = static_cast<size_t>(patch[i]);
      area += face_area[f];
      for_each_neighbour(topo, f, [&](int g) {
        const size_t gi = static_cast<size_t>(g);
        if (!done[gi] && comp[gi] == comp[s] && normals[gi].dot(normals[s]) >= cos_plane) done[gi] = 1, patch.push_back(g);
      });
    }
    total[static_cast<size_t>(comp[s])] += area;
    if (area >= o.plane_min_area) planar[static_cast<size_t>(comp[s])] += area;
  }
  for (size_t k = 0; k < planar.size(); ++k) planar[k] = total[k] > 0 ? planar[k] / total[k] : 0;
  return planar;
}

/// Connected smooth candidates that are tall and large enough become buildings when most of their
/// surface lies in large planes; tall, large and not planar they are vegetation (tree crowns that the
/// producer simplified into smooth blobs), else they stay `other`. Returns the buildings' count.
/// face_area: 3D area per face.
int promote_buildings(const std::vector<double>& face_area, const Topology& topo, const std::vector<uint8_t>& candidate,
                      const std::vector<Vec3>& normals, const ClassifyOptions& o, Classification& c, std::vector<int>& cls) {
  std::vector<int> lab(candidate.size(), -1);
  for (size_t f = 0; f < candidate.size(); ++f)
    if (candidate[f]) lab[f] = 0;
  int n = 0;
  const std::vector<int> comp = label_components(topo, lab, n);
  std::vector<double> top(static_cast<size_t>(n), -kInf), area(static_cast<size_t>(n), 0);
  for (size_t f = 0; f < comp.size(); ++f) {
    if (comp[f] < 0) continue;
    top[static_cast<size_t>(comp[f])] = std::max(top[static_cast<size_t>(comp[f])], c.height[f]);
    area[static_cast<size_t>(comp[f])] += face_area[f];
  }
  const std::vector<double> planar = planar_fractions(face_area, topo, comp, n, normals, o);
  int buildings = 0;
  std::vector<int> verdict(static_cast<size_t>(n), static_cast<int>(FaceClass::Other));
  for (size_t k = 0; k < verdict.size(); ++k) {
    if (top[k] < o.building_min_height || area[k] < o.building_min_area) continue;
    if (planar[k] >= o.building_min_planar_fraction) {
      verdict[k] = static_cast<int>(FaceClass::Building), ++buildings;
    } else {
      verdict[k] = static_cast<int>(FaceClass::Vegetation), ++c.nonplanar_components;
    }
  }
  for (size_t f = 0; f < comp.size(); ++f)
    if (comp[f] >= 0) cls[f] = verdict[static_cast<size_t>(comp[f])];
  return buildings;
}

/// Same-class islands under min_component_faces take the class most of their border neighbours
/// hold (ties: the lower class id). One pass, islands in face order. Returns how many changed.
int absorb_islands(const Topology& topo, int min_faces, std::vector<int>& cls) {
  int n = 0;
  const std::vector<int> comp = label_components(topo, cls, n);
  std::vector<std::vector<int>> members(static_cast<size_t>(n));
  for (size_t f = 0; f < comp.size(); ++f) members[static_cast<size_t>(comp[f])].push_back(static_cast<int>(f));
  int changed = 0;
  for (const auto& mem : members) {
    if (static_cast<int>(mem.size()) >= min_faces) continue;
    std::array<int, kNumClasses> votes{};
    const int own = cls[static_cast<size_t>(mem[0])];
    for (int f : mem)
      for_each_neighbour(topo, static_cast<size_t>(f), [&](int g) {
        if (cls[static_cast<size_t>(g)] != own) ++votes[static_cast<size_t>(cls[static_cast<size_t>(g)])];
      });
    const auto best = std::max_element(votes.begin(), votes.end());
    if (*best == 0) continue;  // an isolated piece keeps its class
    for (int f : mem) cls[static_cast<size_t>(f)] = static_cast<int>(best - votes.begin());
    ++changed;
  }
  return changed;
}

}  // namespace

std::vector<int> label_components(const Topology& topo, const std::vector<int>& label, int& count) {
  std::vector<int> comp(label.size(), -1);
  count = 0;
  std::vector<int> stack;
  for (size_t s = 0; s < label.size(); ++s) {
    if (label[s] < 0 || comp[s] >= 0) continue;
    comp[s] = count;
    stack.assign(1, static_cast<int>(s));
    while (!stack.empty()) {
      const size_t f = static_cast<size_t>(stack.back());
      stack.pop_back();
      for_each_neighbour(topo, f, [&](int g) {
        if (comp[static_cast<size_t>(g)] < 0 && label[static_cast<size_t>(g)] == label[s])
          comp[static_cast<size_t>(g)] = count, stack.push_back(g);
      });
    }
    ++count;
  }
  return comp;
}

Classification classify_faces(const TexturedMesh& mesh, const Topology& topo, const ClassifyOptions& o) {
  Classification c;
  const size_t nf = mesh.faces.size();
  std::vector<Vec3> centroids(nf);
  for (size_t f = 0; f < nf; ++f) centroids[f] = centroid(mesh, f);
  const std::vector<Vec3> normals = filter_face_normals(mesh, topo, o.normal_filter_iterations, 30.0 * M_PI / 180.0);
  std::vector<double> area(nf);
  for (size_t f = 0; f < nf; ++f) area[f] = face_area_3d(mesh, f);
  c.height = heights_above_ground(centroids, normals, o);
  patch_features(area, topo, normals, o.patch_rings, c);
  std::vector<uint8_t> candidate;
  std::vector<int> cls = initial_classes(normals, c, o, candidate);
  promote_buildings(area, topo, candidate, normals, o, c, cls);
  c.relabelled_islands = absorb_islands(topo, o.min_component_faces, cls);
  c.face_class.resize(nf);
  std::vector<int> building(nf, -1);
  for (size_t f = 0; f < nf; ++f) {
    c.face_class[f] = static_cast<FaceClass>(cls[f]);
    ++c.faces_per_class[static_cast<size_t>(cls[f])];
    c.area_per_class[static_cast<size_t>(cls[f])] += area[f];
    if (c.face_class[f] == FaceClass::Building) building[f] = 0;
  }
  label_components(topo, building, c.building_components);
  return c;
}

}  // namespace texdefrag::detectors::semantic
