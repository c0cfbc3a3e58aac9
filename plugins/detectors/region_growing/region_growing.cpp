// detectors.region_growing: planar regions by patch-based region growing with the Comprehensive
// Planarity Index and three refinements, after
//   Liu et al. 2024, "A Planar Feature-Preserving Texture Defragmentation Method for 3D Urban
//   Building Models", Remote Sensing 16(22):4154, section 2.1 (patch identification, patch-based
//   region growing, region growing refinements). Readings of what the paper leaves open are ours and
//   documented in docs/detectors.md.
//
// Outline: units = input charts (patches), where a chart whose faces fold over a crease is first
// split by normal clustering; seeds in decreasing area; a neighbour unit joins when its normal is
// within the angle threshold of the region's refitted plane normal and its CPI passes; restart while
// units remain. Then: elongated strips are dissolved into their neighbours, small smoothly curved
// pieces are grouped into one component, small regions join the neighbouring region whose plane they
// fit (tiny ones the one with more faces); then (our additions, docs/detectors.md refinements 9-11)
// coplanar regions are grouped and speckle lying on their planes joins them, pieces of one cylinder
// (silos, curved facades) are joined across smooth borders, and small regions or clusters enclosed
// by one region join it whatever their angle.
#include "common/normals.h"
#include "common/planarity.h"
#include "common/region_output.h"
#include "common/units.h"
#include "texdefrag/stage/registry.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

namespace texdefrag::detectors {
namespace {

constexpr const char* kName = "detectors.region_growing";

struct Params {
  double angle = 25 * M_PI / 180;  // radians
  double cpi_min = 0.6;
  CpiWeights w;
  bool split = true;
  double split_min_fraction = 0.15;
  bool strips = true;
  double strip_compactness = 0.04;
  double strip_angle = 40 * M_PI / 180;
  bool curved = true;
  double curved_max_area_fraction = 0.02;
  double curved_border_angle = 20 * M_PI / 180;
  bool jagged = true;
  int min_region_faces = 12;
  int smoothing_iterations = 5;
  double smoothing_sigma = 30 * M_PI / 180;
  int fit_min_faces = 8;
  double max_plane_distance = 1.0;  // mean edge lengths
  int tiny_region_faces = 3;
  bool enclosed = true;
  double enclosed_max_fraction = 0.1;
  double enclosed_border_fraction = 0.75;
  bool coplanar = true;
  double coplanar_angle = 20 * M_PI / 180;
  double coplanar_max_offset = 0.25;  // mean edge lengths
  double coplanar_max_rms = 0.5;      // mean edge lengths
  int coplanar_min_faces = 12;
  double coplanar_min_coherence = 0.5;
  double speckle_angle = 45 * M_PI / 180;
  double speckle_max_distance = 0.5;  // mean edge lengths
  double speckle_max_fraction = 0.3;
  bool cylinders = true;
  double cylinder_axis_angle = 15 * M_PI / 180;
  double cylinder_max_rms = 0.5;     // mean edge lengths
  double cylinder_max_radius = 50;   // mean edge lengths
  double cylinder_border_ratio = 0.6;
  double edge = 0;                  // mean edge length of the model (set in detect)
};

Params read_params(const Options& o) {
  Params p;
  p.angle = o.get_double("angle_threshold_deg") * M_PI / 180;
  p.cpi_min = o.get_double("cpi_min");
  p.w.flatness = o.get_double("w_flatness");
  p.w.compactness = o.get_double("w_compactness");
  p.w.normal = o.get_double("w_normal");
  p.split = o.get_bool("split_nonplanar_patches");
  p.split_min_fraction = o.get_double("split_min_fraction");
  p.strips = o.get_bool("elongated_strips");
  p.strip_compactness = o.get_double("strip_compactness");
  p.strip_angle = o.get_double("strip_max_angle_deg") * M_PI / 180;
  p.curved = o.get_bool("curved_components");
  p.curved_max_area_fraction = o.get_double("curved_max_area_fraction");
  p.curved_border_angle = o.get_double("curved_border_angle_deg") * M_PI / 180;
  p.jagged = o.get_bool("jagged_borders");
  p.min_region_faces = static_cast<int>(o.get_int("min_region_faces"));
  p.smoothing_iterations = static_cast<int>(o.get_int("normal_smoothing_iterations"));
  p.smoothing_sigma = o.get_double("normal_smoothing_sigma_deg") * M_PI / 180;
  p.fit_min_faces = static_cast<int>(o.get_int("fit_min_faces"));
  p.max_plane_distance = o.get_double("max_plane_distance");
  p.tiny_region_faces = static_cast<int>(o.get_int("tiny_region_faces"));
  p.enclosed = o.get_bool("absorb_enclosed");
  p.enclosed_max_fraction = o.get_double("enclosed_max_fraction");
  p.enclosed_border_fraction = o.get_double("enclosed_border_fraction");
  p.coplanar = o.get_bool("coplanar_grouping");
  p.coplanar_angle = o.get_double("coplanar_angle_deg") * M_PI / 180;
  p.coplanar_max_offset = o.get_double("coplanar_max_offset");
  p.coplanar_max_rms = o.get_double("coplanar_max_rms");
  p.coplanar_min_faces = static_cast<int>(o.get_int("coplanar_min_faces"));
  p.coplanar_min_coherence = o.get_double("coplanar_min_coherence");
  p.speckle_angle = o.get_double("speckle_angle_deg") * M_PI / 180;
  p.speckle_max_distance = o.get_double("speckle_max_distance");
  p.speckle_max_fraction = o.get_double("speckle_max_fraction");
  p.cylinders = o.get_bool("curved_surfaces");
  p.cylinder_axis_angle = o.get_double("cylinder_axis_angle_deg") * M_PI / 180;
  p.cylinder_max_rms = o.get_double("cylinder_max_rms");
  p.cylinder_max_radius = o.get_double("cylinder_max_radius");
  p.cylinder_border_ratio = o.get_double("cylinder_border_ratio");
  return p;
}

struct UnionFind {
  std::vector<int> p;
  explicit UnionFind(size_t n) : p(n) { std::iota(p.begin(), p.end(), 0); }
  int find(int x) {
    while (p[static_cast<size_t>(x)] != x) x = p[static_cast<size_t>(x)] = p[static_cast<size_t>(p[static_cast<size_t>(x)])];
    return x;
  }
};

/// Units: input charts, each split into normal clusters when it is not planar (section 2 of the doc).
/// fn: the (filtered) unit face normals used for clustering. Returns face -> unit and fills the
/// split counters.
std::vector<int> make_units(const StageContext& ctx, const Params& p, const std::vector<Vec3>& fn, int& num_units,
                            json& rep) {
  const TexturedMesh& mesh = *ctx.mesh;
  const Topology& topo = *ctx.topology;
  const Atlas& in = ctx.input_charts->atlas;
  const size_t nf = mesh.faces.size();
  std::vector<int> unit(nf, -1);
  const std::vector<std::vector<int>> chart_faces = in.chart_faces();
  std::vector<double> fa(nf, 0);
  for (size_t f = 0; f < nf; ++f)
    if (in.face_chart[f] >= 0) fa[f] = face_area_3d(mesh, f);
  num_units = 0;
  size_t split_charts = 0, split_units = 0;
  std::vector<int> cluster(nf, -1);
  std::vector<Vec3> csum;
  std::vector<double> carea;
  for (size_t c = 0; c < chart_faces.size(); ++c) {
    std::vector<int> faces = chart_faces[c];
    bool do_split = false;
    if (p.split && faces.size() >= 2) {
      // note: seeds in decreasing face area; a face joins a cluster when its normal is within the
      // growing threshold of the cluster's area-weighted mean normal (same criterion as growth).
      std::stable_sort(faces.begin(), faces.end(), [&](int a, int b) { return fa[static_cast<size_t>(a)] > fa[static_cast<size_t>(b)]; });
      csum.clear();
      carea.clear();
      double total = 0;
      for (int seed : faces) {
        total += fa[static_cast<size_t>(seed)];
        if (cluster[static_cast<size_t>(seed)] >= 0) continue;
        const int id = static_cast<int>(csum.size());
        csum.push_back(fa[static_cast<size_t>(seed)] * fn[static_cast<size_t>(seed)]);
        carea.push_back(fa[static_cast<size_t>(seed)]);
        cluster[static_cast<size_t>(seed)] = id;
        std::deque<int> q{seed};
        while (!q.empty()) {
          const int f = q.front();
          q.pop_front();
          for (int k = 0; k < 3; ++k) {
            const Edge& e = topo.edges[static_cast<size_t>(topo.face_edge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
            for (int i = 0; i < e.num_faces; ++i) {
              const int g = topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face;
              if (g == f || cluster[static_cast<size_t>(g)] >= 0 || in.face_chart[static_cast<size_t>(g)] != static_cast<int>(c)) continue;
              if (!(fa[static_cast<size_t>(g)] > 0) || normal_angle(fn[static_cast<size_t>(g)], csum[static_cast<size_t>(id)]) >= p.angle) continue;
              cluster[static_cast<size_t>(g)] = id;
              csum[static_cast<size_t>(id)] += fa[static_cast<size_t>(g)] * fn[static_cast<size_t>(g)];
              carea[static_cast<size_t>(id)] += fa[static_cast<size_t>(g)];
              q.push_back(g);
            }
          }
        }
      }
      int big = 0;
      for (double a : carea) big += total > 0 && a >= p.split_min_fraction * total;
      do_split = big >= 2;
    }
    if (do_split) {
      ++split_charts;
      split_units += csum.size();
      for (int f : faces) unit[static_cast<size_t>(f)] = num_units + cluster[static_cast<size_t>(f)];
      num_units += static_cast<int>(csum.size());
    } else {
      for (int f : faces) unit[static_cast<size_t>(f)] = num_units;
      ++num_units;
    }
    for (int f : faces) cluster[static_cast<size_t>(f)] = -1;
  }
  rep["patches"] = chart_faces.size();
  rep["patches_split"] = split_charts;
  rep["units_from_split_patches"] = split_units;
  return unit;
}

/// Units with their plane moments and fits (the graph) plus, per unit, the sum of its faces'
/// area-weighted filtered normals: the normal used for units too small for a covariance fit.
struct Units {
  UnitGraph g;
  std::vector<Vec3> smooth;  ///< per unit: sum of area * filtered face normal
  std::vector<double> open;  ///< per unit: 3D length of its edges with no textured face of another unit
  std::vector<Vec3> face_centroid;  ///< per face, relative to the moments' reference point
  std::vector<double> face_area;    ///< per face (3D)
};

/// Per unit, the 3D length of the edges where it has no textured neighbour face (mesh boundary,
/// tile cracks, untextured faces): border that belongs to no region.
std::vector<double> open_border_lengths(const TexturedMesh& mesh, const Topology& topo, const UnitGraph& g) {
  std::vector<double> open(static_cast<size_t>(g.num_units), 0.0);
  for (const Edge& e : topo.edges) {
    int unit = -1;
    bool other = false;
    for (int i = 0; i < e.num_faces; ++i) {
      const int u = g.face_unit[static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face)];
      if (u < 0) continue;
      if (unit < 0) unit = u;
      else if (u != unit) other = true;
    }
    if (unit < 0 || other) continue;
    // Every textured face on this edge is in one unit: open unless two of its own faces meet here.
    int count = 0;
    for (int i = 0; i < e.num_faces; ++i)
      count += g.face_unit[static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face)] >= 0;
    if (count >= 2) continue;
    open[static_cast<size_t>(unit)] += (mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.a)])] -
                                        mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
  }
  return open;
}

/// The normal a set of faces is judged by: the covariance fit's normal (the paper) when the set has
/// at least fit_min_faces faces, else the direction of its area-weighted filtered normals (the
/// covariance of 1-3 noisy triangles says little about the surface they lie on).
Vec3 reliable_normal(const PlaneMoments& m, const PlaneFit& fit, const Vec3& smooth, const Params& p) {
  if (fit.valid && m.faces >= p.fit_min_faces) return fit.normal;
  const double len = smooth.norm();
  if (len > 0) return smooth / len;
  return fit.normal;
}

Vec3 unit_normal(const Units& U, int u, const Params& p) {
  return reliable_normal(U.g.moments[static_cast<size_t>(u)], U.g.fits[static_cast<size_t>(u)],
                         U.smooth[static_cast<size_t>(u)], p);
}

/// Per-region aggregates of a unit labelling.
struct RegionSet {
  int n = 0;
  std::vector<PlaneMoments> m;
  std::vector<PlaneFit> fit;
  std::vector<Vec3> smooth;
  std::vector<std::map<int, double>> nbr;  // neighbour region -> shared border length
};

RegionSet aggregate(const Units& U, const std::vector<int>& unit_region, int n) {
  const UnitGraph& g = U.g;
  RegionSet rs;
  rs.n = n;
  rs.m.assign(static_cast<size_t>(n), PlaneMoments{});
  rs.smooth.assign(static_cast<size_t>(n), Vec3::Zero());
  rs.nbr.assign(static_cast<size_t>(n), {});
  for (int u = 0; u < g.num_units; ++u) {
    const int r = unit_region[static_cast<size_t>(u)];
    rs.m[static_cast<size_t>(r)].add(g.moments[static_cast<size_t>(u)]);
    rs.smooth[static_cast<size_t>(r)] += U.smooth[static_cast<size_t>(u)];
    for (int i = g.adj_offset[static_cast<size_t>(u)]; i < g.adj_offset[static_cast<size_t>(u) + 1]; ++i) {
      const int s = unit_region[static_cast<size_t>(g.adj[static_cast<size_t>(i)])];
      if (s != r) rs.nbr[static_cast<size_t>(r)][s] += g.adj_length[static_cast<size_t>(i)];
    }
  }
  rs.fit.resize(static_cast<size_t>(n));
  for (size_t r = 0; r < static_cast<size_t>(n); ++r) rs.fit[r] = fit_plane(rs.m[r]);
  return rs;
}

/// Renumbers region labels densely (order of first unit). Returns the count.
int compact_labels(std::vector<int>& unit_region) {
  std::map<int, int> id;
  for (int& r : unit_region) r = id.emplace(r, static_cast<int>(id.size())).first->second;
  return static_cast<int>(id.size());
}

/// Whether a set (moments m, normal n) fits the plane of a region (fit f, normal rn): normals
/// within max_angle (radians) and RMS distance of the set to the region's plane within
/// max_plane_distance mean edge lengths.
bool fits_plane(const PlaneMoments& m, const Vec3& n, const PlaneFit& f, const Vec3& rn, double max_angle,
                const Params& p) {
  if (!f.valid || normal_angle(n, rn) >= max_angle) return false;
  return plane_rms_distance(m, f.centroid, rn) <= p.max_plane_distance * p.edge;
}

/// Whether the face normals of a set agree (|sum of area-weighted face normals| / area at least
/// coplanar_min_coherence): 1 for a plane, ~0.9 for a noisy photogrammetric facade, low for a
/// tree crown or clutter whose faces point every way.
bool coherent(const PlaneMoments& m, const Params& p) {
  return m.area > 0 && m.normal_sum.norm() >= p.coplanar_min_coherence * m.area;
}

/// Patch-based growing (section 2.1.2). Units without area are left unassigned (-1).
std::vector<int> grow(const Units& U, const Params& p, int& n, json& rep) {
  const UnitGraph& g = U.g;
  const size_t nu = static_cast<size_t>(g.num_units);
  std::vector<int> order;
  for (int u = 0; u < g.num_units; ++u)
    if (g.fits[static_cast<size_t>(u)].valid) order.push_back(u);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return g.moments[static_cast<size_t>(a)].area > g.moments[static_cast<size_t>(b)].area;
  });
  std::vector<Vec3> un(nu);
  for (int u = 0; u < g.num_units; ++u) un[static_cast<size_t>(u)] = unit_normal(U, u, p);
  std::vector<int> region(nu, -1);
  size_t angle_rej = 0, cpi_rej = 0;
  n = 0;
  std::deque<int> seeds;
  for (int s0 : order) {
    if (region[static_cast<size_t>(s0)] >= 0) continue;
    const int r = n++;
    PlaneMoments rm = g.moments[static_cast<size_t>(s0)];
    Vec3 rsmooth = U.smooth[static_cast<size_t>(s0)];
    Vec3 rn = un[static_cast<size_t>(s0)];
    region[static_cast<size_t>(s0)] = r;
    seeds.assign(1, s0);
    while (!seeds.empty()) {
      const int s = seeds.front();
      seeds.pop_front();
      for (int i = g.adj_offset[static_cast<size_t>(s)]; i < g.adj_offset[static_cast<size_t>(s) + 1]; ++i) {
        const int v = g.adj[static_cast<size_t>(i)];
        if (region[static_cast<size_t>(v)] >= 0 || !g.fits[static_cast<size_t>(v)].valid) continue;
        const double theta = normal_angle(un[static_cast<size_t>(v)], rn);
        if (theta >= p.angle) {
          ++angle_rej;
          continue;
        }
        if (planarity_index(g.fits[static_cast<size_t>(v)], theta, p.w) < p.cpi_min) {
          ++cpi_rej;
          continue;
        }
        region[static_cast<size_t>(v)] = r;
        rm.add(g.moments[static_cast<size_t>(v)]);
        rsmooth += U.smooth[static_cast<size_t>(v)];
        rn = reliable_normal(rm, fit_plane(rm), rsmooth, p);
        seeds.push_back(v);
      }
    }
  }
  rep["grown_regions"] = n;
  rep["angle_rejections"] = angle_rej;
  rep["cpi_rejections"] = cpi_rej;
  return region;
}

/// Units without area join the neighbouring region sharing the longest border (else their own).
void place_zero_area_units(const UnitGraph& g, std::vector<int>& region, int& n, json& rep) {
  size_t zero = 0;
  bool changed = true;
  while (changed) {
    changed = false;
    for (int u = 0; u < g.num_units; ++u) {
      if (region[static_cast<size_t>(u)] >= 0) continue;
      std::map<int, double> len;
      for (int i = g.adj_offset[static_cast<size_t>(u)]; i < g.adj_offset[static_cast<size_t>(u) + 1]; ++i) {
        const int r = region[static_cast<size_t>(g.adj[static_cast<size_t>(i)])];
        if (r >= 0) len[r] += g.adj_length[static_cast<size_t>(i)];
      }
      if (len.empty()) continue;
      region[static_cast<size_t>(u)] = std::max_element(len.begin(), len.end(), [](const auto& a, const auto& b) { return a.second < b.second; })->first;
      ++zero;
      changed = true;
    }
  }
  for (int u = 0; u < g.num_units; ++u)
    if (region[static_cast<size_t>(u)] < 0) {
      region[static_cast<size_t>(u)] = n++;
      ++zero;
    }
  rep["zero_area_units"] = zero;
}

/// Refinement: elongated strips (compactness < threshold, a neighbour with more faces) are dissolved;
/// each of their units goes to the adjacent non-strip region whose plane it fits (fits_plane with
/// the wider strip angle: strips are ledges, beams, cornices tilted against their facade),
/// sharing the longest border with it; units that fit no neighbour stay in the strip's region.
void dissolve_strips(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  const UnitGraph& g = U.g;
  const RegionSet rs = aggregate(U, region, n);
  std::vector<uint8_t> strip(static_cast<size_t>(n), 0);
  std::vector<Vec3> rn(static_cast<size_t>(n));
  size_t strips = 0;
  for (int r = 0; r < n; ++r) {
    const PlaneFit& f = rs.fit[static_cast<size_t>(r)];
    rn[static_cast<size_t>(r)] = reliable_normal(rs.m[static_cast<size_t>(r)], f, rs.smooth[static_cast<size_t>(r)], p);
    if (!f.valid || compactness_term(f.eigenvalues[1], f.eigenvalues[2]) >= p.strip_compactness) continue;
    bool bigger = false;
    for (const auto& [s, len] : rs.nbr[static_cast<size_t>(r)])
      bigger |= rs.m[static_cast<size_t>(s)].faces > rs.m[static_cast<size_t>(r)].faces;
    if (bigger) {
      strip[static_cast<size_t>(r)] = 1;
      ++strips;
    }
  }
  std::vector<uint8_t> free(static_cast<size_t>(g.num_units), 0);
  for (int u = 0; u < g.num_units; ++u) free[static_cast<size_t>(u)] = strip[static_cast<size_t>(region[static_cast<size_t>(u)])];
  size_t moved = 0, kept = 0;
  bool changed = true;
  while (changed) {
    changed = false;
    for (int u = 0; u < g.num_units; ++u) {
      if (!free[static_cast<size_t>(u)]) continue;
      std::map<int, double> len;
      for (int i = g.adj_offset[static_cast<size_t>(u)]; i < g.adj_offset[static_cast<size_t>(u) + 1]; ++i) {
        const int v = g.adj[static_cast<size_t>(i)];
        if (!free[static_cast<size_t>(v)]) len[region[static_cast<size_t>(v)]] += g.adj_length[static_cast<size_t>(i)];
      }
      const Vec3 n_u = unit_normal(U, u, p);
      int best = -1;
      double best_len = 0;
      for (const auto& [r, l] : len) {
        if (l <= best_len || strip[static_cast<size_t>(r)]) continue;
        if (!fits_plane(g.moments[static_cast<size_t>(u)], n_u, rs.fit[static_cast<size_t>(r)], rn[static_cast<size_t>(r)], p.strip_angle, p)) continue;
        best = r;
        best_len = l;
      }
      if (best < 0) continue;
      region[static_cast<size_t>(u)] = best;
      free[static_cast<size_t>(u)] = 0;
      ++moved;
      changed = true;
    }
  }
  for (int u = 0; u < g.num_units; ++u) kept += free[static_cast<size_t>(u)];
  n = compact_labels(region);
  rep["strip_regions"] = strips;
  rep["strip_units_moved"] = moved;
  rep["strip_units_kept"] = kept;
}

/// Refinement: adjacent small regions (area under a fraction of the textured area) whose shared
/// border is smooth (border-length-weighted mean angle between the units facing each other under a
/// threshold) are grouped into one component, as long as the component stays small.
void group_curved(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  const UnitGraph& g = U.g;
  const RegionSet rs = aggregate(U, region, n);
  double total = 0;
  for (const auto& m : rs.m) total += m.area;
  const double cap = p.curved_max_area_fraction * total;
  std::vector<Vec3> un(static_cast<size_t>(g.num_units));
  for (int u = 0; u < g.num_units; ++u) un[static_cast<size_t>(u)] = unit_normal(U, u, p);
  // Border angle between adjacent regions, weighted by shared length.
  std::map<std::pair<int, int>, std::pair<double, double>> border;  // (angle * len, len)
  for (int u = 0; u < g.num_units; ++u)
    for (int i = g.adj_offset[static_cast<size_t>(u)]; i < g.adj_offset[static_cast<size_t>(u) + 1]; ++i) {
      const int v = g.adj[static_cast<size_t>(i)];
      const int a = region[static_cast<size_t>(u)], b = region[static_cast<size_t>(v)];
      if (a >= b || !(rs.m[static_cast<size_t>(a)].area < cap) || !(rs.m[static_cast<size_t>(b)].area < cap)) continue;
      const double len = g.adj_length[static_cast<size_t>(i)];
      auto& e = border[{a, b}];
      e.first += len * normal_angle(un[static_cast<size_t>(u)], un[static_cast<size_t>(v)]);
      e.second += len;
    }
  std::vector<std::tuple<double, int, int>> pairs;
  for (const auto& [k, e] : border)
    if (e.second > 0 && e.first / e.second < p.curved_border_angle) pairs.emplace_back(e.first / e.second, k.first, k.second);
  std::sort(pairs.begin(), pairs.end());
  UnionFind uf(static_cast<size_t>(n));
  std::vector<double> area(static_cast<size_t>(n));
  std::vector<int> members(static_cast<size_t>(n), 1);
  for (int r = 0; r < n; ++r) area[static_cast<size_t>(r)] = rs.m[static_cast<size_t>(r)].area;
  size_t grouped = 0;
  for (const auto& [ang, a0, b0] : pairs) {
    const int a = uf.find(a0), b = uf.find(b0);
    if (a == b || !(area[static_cast<size_t>(a)] + area[static_cast<size_t>(b)] < cap)) continue;
    uf.p[static_cast<size_t>(b)] = a;
    area[static_cast<size_t>(a)] += area[static_cast<size_t>(b)];
    members[static_cast<size_t>(a)] += members[static_cast<size_t>(b)];
    ++grouped;
  }
  size_t components = 0;
  for (int r = 0; r < n; ++r) components += uf.find(r) == r && members[static_cast<size_t>(r)] >= 2;
  for (int& r : region) r = uf.find(r);
  n = compact_labels(region);
  rep["curved_components"] = components;
  rep["curved_merges"] = grouped;
}

/// Refinement (jagged borders): regions with fewer than min_region_faces faces, smallest first,
/// join the neighbouring region whose plane they fit (fits_plane: angle and distance), the one with
/// the most faces among those; a region that fits none stays alone unless it has at most
/// tiny_region_faces faces, then it joins the neighbour with the most faces (the paper's rule).
/// Sizes, moments and normals are updated as regions grow.
void absorb_small(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  const RegionSet rs = aggregate(U, region, n);
  std::vector<PlaneMoments> m = rs.m;
  std::vector<Vec3> smooth = rs.smooth;
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return m[static_cast<size_t>(a)].faces < m[static_cast<size_t>(b)].faces; });
  UnionFind uf(static_cast<size_t>(n));
  std::vector<std::vector<int>> members(static_cast<size_t>(n));
  for (int r = 0; r < n; ++r) members[static_cast<size_t>(r)] = {r};
  size_t absorbed = 0, by_size = 0, kept = 0, moved_faces = 0;
  for (int r : order) {
    const int root = uf.find(r);
    if (root != r || m[static_cast<size_t>(root)].faces >= p.min_region_faces) continue;
    std::map<int, double> len;
    for (int mb : members[static_cast<size_t>(root)])
      for (const auto& [s, l] : rs.nbr[static_cast<size_t>(mb)]) len[uf.find(s)] += l;
    const PlaneMoments& sm = m[static_cast<size_t>(root)];
    const Vec3 sn = reliable_normal(sm, fit_plane(sm), smooth[static_cast<size_t>(root)], p);
    int best = -1, any = -1;
    double best_len = 0, any_len = 0;
    auto better = [&](int cand, double l, int cur, double cur_len) {
      if (cur < 0) return true;
      const int fc = m[static_cast<size_t>(cand)].faces, fb = m[static_cast<size_t>(cur)].faces;
      return fc > fb || (fc == fb && l > cur_len);
    };
    for (const auto& [s, l] : len) {
      if (s == root) continue;
      if (better(s, l, any, any_len)) any = s, any_len = l;
      const PlaneFit tf = fit_plane(m[static_cast<size_t>(s)]);
      const Vec3 tn = reliable_normal(m[static_cast<size_t>(s)], tf, smooth[static_cast<size_t>(s)], p);
      if (fits_plane(sm, sn, tf, tn, p.angle, p) && better(s, l, best, best_len)) best = s, best_len = l;
    }
    if (best < 0 && sm.faces <= p.tiny_region_faces && any >= 0) {
      best = any;
      ++by_size;
    }
    if (best < 0) {
      ++kept;
      continue;
    }
    uf.p[static_cast<size_t>(root)] = best;
    moved_faces += static_cast<size_t>(sm.faces);
    m[static_cast<size_t>(best)].add(sm);
    smooth[static_cast<size_t>(best)] += smooth[static_cast<size_t>(root)];
    auto& mb = members[static_cast<size_t>(best)];
    mb.insert(mb.end(), members[static_cast<size_t>(root)].begin(), members[static_cast<size_t>(root)].end());
    members[static_cast<size_t>(root)].clear();
    ++absorbed;
  }
  for (int& r : region) r = uf.find(r);
  n = compact_labels(region);
  rep["jagged_regions_absorbed"] = absorbed;
  rep["jagged_absorbed_by_size"] = by_size;
  rep["jagged_small_regions_kept"] = kept;
  rep["jagged_faces_moved"] = moved_faces;
}

/// absorb_enclosed's step (b): the cluster of small regions around region r of `rs` (n regions):
/// r, then by flooding over neighbours that are not `largest`, not touched and each below `cap`
/// faces. Empty when the cluster reaches `cap` faces together (r alone included).
std::vector<int> enclosed_cluster(const RegionSet& rs, const std::vector<uint8_t>& touched, int n, int r, int largest,
                                  double cap) {
  std::vector<int> members{r};
  std::vector<uint8_t> seen(static_cast<size_t>(n), 0);
  seen[static_cast<size_t>(r)] = 1;
  double faces = rs.m[static_cast<size_t>(r)].faces;
  if (!(faces < cap)) return {};
  for (size_t k = 0; k < members.size(); ++k)
    for (const auto& [t, l] : rs.nbr[static_cast<size_t>(members[k])]) {
      if (t == largest || seen[static_cast<size_t>(t)] || touched[static_cast<size_t>(t)] ||
          !(rs.m[static_cast<size_t>(t)].faces < cap))
        continue;
      seen[static_cast<size_t>(t)] = 1;
      members.push_back(t);
      faces += rs.m[static_cast<size_t>(t)].faces;
      if (!(faces < cap)) return {};
    }
  return members;
}

/// Refinement 11 (enclosed regions, our addition for the paper's intent that details end up inside
/// their facade's region): a region whose border is at least enclosed_border_fraction shared with
/// one neighbouring region (border = edges shared with other regions plus its open edges) and that
/// has fewer than enclosed_max_fraction of that neighbour's faces joins it, whatever its angle.
/// The same holds for a connected cluster of such small regions enclosed together.
/// Passes repeat until nothing changes; within a pass a region that joins one is never a receiver
/// and a receiver is not judged itself, so every decision uses borders valid for that pass.
void absorb_enclosed(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  const UnitGraph& g = U.g;
  size_t absorbed = 0, moved_faces = 0, passes = 0, groups = 0;
  for (;;) {
    const RegionSet rs = aggregate(U, region, n);
    std::vector<double> open(static_cast<size_t>(n), 0.0);
    for (int u = 0; u < g.num_units; ++u) open[static_cast<size_t>(region[static_cast<size_t>(u)])] += U.open[static_cast<size_t>(u)];
    std::vector<int> order(static_cast<size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return rs.m[static_cast<size_t>(a)].faces < rs.m[static_cast<size_t>(b)].faces; });
    std::vector<int> target(static_cast<size_t>(n), -1);
    std::vector<uint8_t> touched(static_cast<size_t>(n), 0);
    size_t joins = 0;
    // Joins `members` (untouched regions, none of them `into`) into region `into` when their outer
    // border (open edges plus edges to regions outside the set) is at least the border fraction
    // shared with `into` and they have fewer than enclosed_max_fraction of its faces together.
    auto try_join = [&](const std::vector<int>& members, int into) {
      if (into < 0 || touched[static_cast<size_t>(into)] == 1) return false;
      std::vector<uint8_t> in(static_cast<size_t>(n), 0);
      for (int r : members) in[static_cast<size_t>(r)] = 1;
      double total = 0, shared = 0;
      long faces = 0;
      for (int r : members) {
        faces += rs.m[static_cast<size_t>(r)].faces;
        total += open[static_cast<size_t>(r)];
        for (const auto& [t, l] : rs.nbr[static_cast<size_t>(r)]) {
          if (in[static_cast<size_t>(t)]) continue;
          total += l;
          if (t == into) shared += l;
        }
      }
      if (!(shared >= p.enclosed_border_fraction * total) ||
          !(static_cast<double>(faces) < p.enclosed_max_fraction * rs.m[static_cast<size_t>(into)].faces))
        return false;
      // Members are done (1); the receiver (2) is not judged itself this pass, but further enclosed
      // regions may still join it: taking in an enclosed set barely changes its outer border.
      for (int r : members) {
        target[static_cast<size_t>(r)] = into;
        touched[static_cast<size_t>(r)] = 1;
      }
      touched[static_cast<size_t>(into)] = 2;
      moved_faces += static_cast<size_t>(faces);
      joins += members.size();
      return true;
    };
    for (int r : order) {
      if (touched[static_cast<size_t>(r)]) continue;
      // (a) The region alone, enclosed by the neighbour sharing its longest border.
      int longest = -1, largest = -1;
      double best_len = 0;
      for (const auto& [t, l] : rs.nbr[static_cast<size_t>(r)]) {
        if (l > best_len) longest = t, best_len = l;
        if (largest < 0 || rs.m[static_cast<size_t>(t)].faces > rs.m[static_cast<size_t>(largest)].faces) largest = t;
      }
      if (try_join({r}, longest)) continue;
      // (b) A cluster of small regions (a balcony cut into several pieces) enclosed together by the
      // region with the most faces around r: flood from r over untouched neighbours other than it
      // that are small against it; give up when the cluster outgrows the size limit.
      if (largest < 0 || touched[static_cast<size_t>(largest)] == 1) continue;
      const double cap = p.enclosed_max_fraction * rs.m[static_cast<size_t>(largest)].faces;
      const std::vector<int> members = enclosed_cluster(rs, touched, n, r, largest, cap);
      if (members.size() > 1 && try_join(members, largest)) ++groups;
    }
    if (joins == 0) break;
    ++passes;
    absorbed += joins;
    for (int& r : region)
      if (target[static_cast<size_t>(r)] >= 0) r = target[static_cast<size_t>(r)];
    n = compact_labels(region);
  }
  rep["enclosed_regions_absorbed"] = absorbed;
  rep["enclosed_faces_moved"] = moved_faces;
  rep["enclosed_passes"] = passes;
  rep["enclosed_groups"] = groups;
}

/// group_coplanar's state: the regions' summed plane moments, smoothed normals and shared borders,
/// joined through a union-find (ids are the regions' at the start; a group is named by its root),
/// with the tests of steps (a) and (b) and their counters.
class CoplanarGrouping {
 public:
  CoplanarGrouping(const Units& U, const Params& p, const std::vector<int>& region, int n)
      : p_(p), n_(n), uf_(static_cast<size_t>(n)) {
    const RegionSet rs = aggregate(U, region, n);
    m_ = rs.m;
    smooth_ = rs.smooth;
    nbr_ = rs.nbr;  // keys may be stale ids: resolve with find
    offset_tol_ = p.coplanar_max_offset * p.edge;
    rms_tol_ = p.coplanar_max_rms * p.edge;
    speckle_tol_ = p.speckle_max_distance * p.edge;
  }

  /// Step (a): joins coplanar pairs of candidates, best-fitting first, each pair re-tested on the
  /// current groups. Returns whether any pair joined.
  bool group_pairs() {
    std::vector<std::tuple<double, int, int, bool>> pairs = candidate_pairs();
    std::sort(pairs.begin(), pairs.end());
    bool changed = false;
    for (const auto& [c0, a0, b0, bridge] : pairs) {
      int a = uf_.find(a0), b = uf_.find(b0);
      if (a == b || coplanar_cost(a, b) < 0) continue;
      if (m_[static_cast<size_t>(a)].faces < m_[static_cast<size_t>(b)].faces) std::swap(a, b);
      join(a, b);
      ++grouped_;
      bridged_ += bridge;
      changed = true;
    }
    return changed;
  }

  /// Step (b): each small group, smallest first, joins the planar large neighbour (much larger than
  /// it) whose plane it lies on best, within speckle_angle and speckle_max_distance. Returns
  /// whether any group joined.
  bool absorb_speckle() {
    std::vector<int> small;
    for (int r = 0; r < n_; ++r)
      if (uf_.find(r) == r && !large(r)) small.push_back(r);
    std::stable_sort(small.begin(), small.end(), [&](int a, int b) {
      return m_[static_cast<size_t>(a)].faces < m_[static_cast<size_t>(b)].faces;
    });
    bool changed = false;
    for (int s : small) {
      if (uf_.find(s) != s || large(s)) continue;
      const PlaneMoments& ms = m_[static_cast<size_t>(s)];
      const Vec3 ns = normal_of(s, fit_plane(ms));
      int best = -1;
      double best_d = 0;
      for (const auto& [t, l] : neighbours(s)) {
        if (!planar(t) || !(ms.faces < p_.speckle_max_fraction * m_[static_cast<size_t>(t)].faces)) continue;
        const PlaneFit ft = fit_plane(m_[static_cast<size_t>(t)]);
        if (!ft.valid) continue;
        const Vec3 nt = normal_of(t, ft);
        const double d = plane_rms_distance(ms, ft.centroid, nt);
        if (normal_angle(ns, nt) >= p_.speckle_angle || d > speckle_tol_ || (best >= 0 && d >= best_d)) continue;
        best = t;
        best_d = d;
      }
      if (best < 0) continue;
      speckle_faces_ += static_cast<size_t>(ms.faces);
      join(best, s);
      ++speckles_;
      changed = true;
    }
    return changed;
  }

  /// Relabels `region` by group (compacted to 0..n-1) and writes the counters into rep.
  void finish(std::vector<int>& region, int& n, size_t passes, json& rep) {
    for (int& r : region) r = uf_.find(r);
    n = compact_labels(region);
    rep["coplanar_joins"] = grouped_;
    rep["coplanar_joins_across_speckle"] = bridged_;
    rep["coplanar_speckle_absorbed"] = speckles_;
    rep["coplanar_speckle_faces"] = speckle_faces_;
    rep["coplanar_passes"] = passes;
    rep["coplanar_rejections"] = {{"angle", rej_angle_}, {"rms", rej_rms_}, {"offset", rej_offset_}};
  }

 private:
  /// A group of at least coplanar_min_faces faces.
  bool large(int r) const { return m_[static_cast<size_t>(r)].faces >= p_.coplanar_min_faces; }
  /// A large group whose face normals agree (a tree crown, clutter has no plane to group by).
  bool planar(int r) const { return large(r) && coherent(m_[static_cast<size_t>(r)], p_); }
  Vec3 normal_of(int r, const PlaneFit& f) const {
    return reliable_normal(m_[static_cast<size_t>(r)], f, smooth_[static_cast<size_t>(r)], p_);
  }

  /// Largest offset of the two parts from their union's plane, or a negative value when (a)'s
  /// angle, RMS or offset test fails (counted per test).
  double coplanar_cost(int a, int b) {
    const PlaneMoments& ma = m_[static_cast<size_t>(a)];
    const PlaneMoments& mb = m_[static_cast<size_t>(b)];
    const PlaneFit fa = fit_plane(ma), fb = fit_plane(mb);
    if (!fa.valid || !fb.valid || normal_angle(normal_of(a, fa), normal_of(b, fb)) >= p_.coplanar_angle) {
      ++rej_angle_;
      return -1.0;
    }
    PlaneMoments mu = ma;
    mu.add(mb);
    const PlaneFit fu = fit_plane(mu);
    if (!fu.valid || std::sqrt(fu.eigenvalues[0]) > rms_tol_) {
      ++rej_rms_;
      return -1.0;
    }
    double worst = 0;
    for (const auto* part : {&ma, &mb}) {
      const PlaneFit& own = part == &ma ? fa : fb;
      const double d = plane_rms_distance(*part, fu.centroid, fu.normal);
      worst = std::max(worst, std::sqrt(std::max(0.0, d * d - own.eigenvalues[0])));
    }
    if (worst > offset_tol_) {
      ++rej_offset_;
      return -1.0;
    }
    return worst;
  }

  /// Joins root `from` into root `into`: moments, smoothed normals and borders add up.
  void join(int into, int from) {
    uf_.p[static_cast<size_t>(from)] = into;
    m_[static_cast<size_t>(into)].add(m_[static_cast<size_t>(from)]);
    smooth_[static_cast<size_t>(into)] += smooth_[static_cast<size_t>(from)];
    auto& dst = nbr_[static_cast<size_t>(into)];
    for (const auto& [t, l] : nbr_[static_cast<size_t>(from)]) dst[t] += l;
    nbr_[static_cast<size_t>(from)].clear();
  }

  /// Current neighbours of root r (other roots) with their shared border length.
  std::map<int, double> neighbours(int r) {
    std::map<int, double> out;
    for (const auto& [t, l] : nbr_[static_cast<size_t>(r)]) {
      const int s = uf_.find(t);
      if (s != r) out[s] += l;
    }
    nbr_[static_cast<size_t>(r)] = out;  // compact the stale keys
    return out;
  }

  /// (a)'s candidate pairs that pass its tests, as (cost, a, b, through a bridge): adjacent planar
  /// large groups; planar large groups around a smaller large one (a pilaster band); planar large
  /// groups around one connected cluster of small groups (speckle).
  std::vector<std::tuple<double, int, int, bool>> candidate_pairs() {
    std::vector<std::tuple<double, int, int, bool>> pairs;  // cost, a, b, through a bridge
    std::map<std::pair<int, int>, bool> seen;
    auto consider = [&](int a, int b, bool bridge) {
      if (a == b) return;
      const auto key = std::minmax(a, b);
      if (!seen.emplace(key, bridge).second) return;
      const double c = coplanar_cost(a, b);
      if (c >= 0) pairs.emplace_back(c, key.first, key.second, bridge);
    };
    std::vector<std::map<int, double>> nbs(static_cast<size_t>(n_));
    for (int r = 0; r < n_; ++r)
      if (uf_.find(r) == r) nbs[static_cast<size_t>(r)] = neighbours(r);
    auto pairs_around = [&](const std::vector<int>& around) {
      for (size_t i = 0; i < around.size(); ++i)
        for (size_t j = i + 1; j < around.size(); ++j) consider(around[i], around[j], true);
    };
    std::vector<uint8_t> flooded(static_cast<size_t>(n_), 0);
    for (int r = 0; r < n_; ++r) {
      if (uf_.find(r) != r) continue;
      const std::map<int, double>& nb = nbs[static_cast<size_t>(r)];
      if (large(r)) {
        if (planar(r))
          for (const auto& [t, l] : nb)
            if (planar(t)) consider(r, t, false);
        // A large region smaller than two large neighbours bridges them (a pilaster band).
        std::vector<int> around;
        for (const auto& [t, l] : nb)
          if (planar(t) && m_[static_cast<size_t>(t)].faces > m_[static_cast<size_t>(r)].faces) around.push_back(t);
        pairs_around(around);
        continue;
      }
      // A connected cluster of small regions (speckle) bridges every large region around it.
      if (flooded[static_cast<size_t>(r)]) continue;
      std::vector<int> cluster{r}, around, touched_large;
      flooded[static_cast<size_t>(r)] = 1;
      for (size_t k = 0; k < cluster.size(); ++k)
        for (const auto& [t, l] : nbs[static_cast<size_t>(cluster[k])]) {
          if (flooded[static_cast<size_t>(t)]) continue;
          flooded[static_cast<size_t>(t)] = 1;
          if (large(t)) {
            touched_large.push_back(t);
            if (planar(t)) around.push_back(t);
          } else {
            cluster.push_back(t);
          }
        }
      for (int t : touched_large) flooded[static_cast<size_t>(t)] = 0;  // large ones may border other clusters
      pairs_around(around);
    }
    return pairs;
  }

  const Params& p_;
  int n_;
  std::vector<PlaneMoments> m_;
  std::vector<Vec3> smooth_;
  std::vector<std::map<int, double>> nbr_;
  UnionFind uf_;
  double offset_tol_ = 0, rms_tol_ = 0, speckle_tol_ = 0;
  size_t rej_angle_ = 0, rej_rms_ = 0, rej_offset_ = 0;  // candidate pairs failing each test of (a)
  size_t grouped_ = 0, bridged_ = 0, speckles_ = 0, speckle_faces_ = 0;
};

/// Refinement (coplanar grouping, our addition; docs/detectors.md refinement 9). Facades come out of
/// growth cut into several coplanar regions (at pilaster bands, tile cracks, bay windows) with small
/// speckle regions between them. Two steps, repeated until nothing changes:
///  (a) grouping: two regions with at least coplanar_min_faces faces each ("large"), adjacent, or
///      both touching a large region smaller than both, or both bordering one connected cluster of
///      small regions (a speckle strip between two facade pieces), join when their fitted
///      normals are within coplanar_angle, the RMS residual of their union's plane fit is at most
///      coplanar_max_rms mean edge lengths, and each one's offset from the union's plane (the RMS
///      distance of its surface to that plane beyond its own residual: the part due to tilt and
///      shift) is at most coplanar_max_offset mean edge lengths. Best-fitting pairs first; groups
///      are refitted from summed moments after every join.
///  (b) speckle: a region with fewer than coplanar_min_faces faces joins the neighbouring large
///      region (at least coplanar_min_faces faces and more than 1/speckle_max_fraction times its
///      faces) whose plane it lies on best: normal within speckle_angle and the smallest RMS distance
///      of its surface to the plane, at most speckle_max_distance mean edge lengths.
/// A wall and a roof (90 degrees) or the ground and a facade never pass the angle tests; a tree
/// crown fails the residual test (a) and is too far from any plane for (b).
void group_coplanar(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  CoplanarGrouping grouping(U, p, region, n);
  size_t passes = 0;
  for (bool changed = true; changed;) {
    ++passes;
    const bool grouped = grouping.group_pairs();
    const bool absorbed = grouping.absorb_speckle();
    changed = grouped || absorbed;
  }
  grouping.finish(region, n, passes, rep);
}

/// Kasa circle fit in the plane perpendicular to `axis` through area-weighted sample points
/// (face centroids). Returns the RMS distance of the samples to the circle (model units) and the
/// radius; rms = infinity when the fit is degenerate (collinear points: no finite circle).
struct CircleFit {
  double rms = std::numeric_limits<double>::infinity();
  double radius = 0;
};

CircleFit fit_circle(const std::vector<int>& faces, const Units& U, const Vec3& axis) {
  // note: an orthonormal basis (e1, e2) of the plane perpendicular to the axis; samples are
  // centred on their weighted mean first so the normal equations stay well conditioned.
  const Vec3 e1 = (std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(axis).normalized();
  const Vec3 e2 = axis.cross(e1);
  double W = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int f : faces) {
    const double w = U.face_area[static_cast<size_t>(f)];
    const Vec3& c = U.face_centroid[static_cast<size_t>(f)];
    mean += w * Eigen::Vector2d(c.dot(e1), c.dot(e2));
    W += w;
  }
  CircleFit out;
  if (!(W > 0)) return out;
  mean /= W;
  // Minimise sum w (x^2 + y^2 + D x + E y + F)^2 over (D, E, F).
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int f : faces) {
    const double w = U.face_area[static_cast<size_t>(f)];
    const Vec3& c = U.face_centroid[static_cast<size_t>(f)];
    const double x = c.dot(e1) - mean.x(), y = c.dot(e2) - mean.y();
    const Eigen::Vector3d row(x, y, 1);
    A += w * row * row.transpose();
    b -= w * (x * x + y * y) * row;
  }
  const Eigen::Vector3d s = A.ldlt().solve(b);
  const double cx = -s[0] / 2, cy = -s[1] / 2, r2 = cx * cx + cy * cy - s[2];
  if (!std::isfinite(r2) || !(r2 > 0)) return out;
  out.radius = std::sqrt(r2);
  double ss = 0;
  for (int f : faces) {
    const double w = U.face_area[static_cast<size_t>(f)];
    const Vec3& c = U.face_centroid[static_cast<size_t>(f)];
    const double x = c.dot(e1) - mean.x() - cx, y = c.dot(e2) - mean.y() - cy;
    const double d = std::sqrt(x * x + y * y) - out.radius;
    ss += w * d * d;
  }
  out.rms = std::sqrt(ss / W);
  return out;
}

/// group_cylinders' candidates: the pairs (sharpness, a, b), a < b, of adjacent coherent regions of
/// `rs` with at least coplanar_min_faces faces each whose border is smooth (sharpness = the
/// length-weighted mean angle between the unit normals `un` facing each other across it, over the
/// angle between the regions' normals, at most cylinder_border_ratio), smoothest first.
std::vector<std::tuple<double, int, int>> smooth_border_pairs(const Units& U, const Params& p, const std::vector<int>& region,
                                                              const RegionSet& rs, const std::vector<Vec3>& un) {
  const UnitGraph& g = U.g;
  std::map<std::pair<int, int>, std::pair<double, double>> border;  // (angle * len, len)
  for (int u = 0; u < g.num_units; ++u)
    for (int i = g.adj_offset[static_cast<size_t>(u)]; i < g.adj_offset[static_cast<size_t>(u) + 1]; ++i) {
      const int v = g.adj[static_cast<size_t>(i)];
      const int a = region[static_cast<size_t>(u)], b = region[static_cast<size_t>(v)];
      if (a >= b || rs.m[static_cast<size_t>(a)].faces < p.coplanar_min_faces || rs.m[static_cast<size_t>(b)].faces < p.coplanar_min_faces ||
          !coherent(rs.m[static_cast<size_t>(a)], p) || !coherent(rs.m[static_cast<size_t>(b)], p))
        continue;
      const double len = g.adj_length[static_cast<size_t>(i)];
      auto& e = border[{a, b}];
      e.first += len * normal_angle(un[static_cast<size_t>(u)], un[static_cast<size_t>(v)]);
      e.second += len;
    }
  // note: on a curved surface cut into pieces the turn is spread over the pieces, so the angle
  // between the units facing each other across the border is a fraction of the angle between the
  // pieces' normals; at a crease (wall/roof, facade corner) the whole turn happens at the border.
  std::vector<std::tuple<double, int, int>> pairs;  // sharpness = border angle / normal angle
  for (const auto& [k, e] : border) {
    if (!(e.second > 0)) continue;
    const size_t a = static_cast<size_t>(k.first), b = static_cast<size_t>(k.second);
    const double turn = normal_angle(reliable_normal(rs.m[a], rs.fit[a], rs.smooth[a], p),
                                     reliable_normal(rs.m[b], rs.fit[b], rs.smooth[b], p));
    if (!(turn > 0)) continue;
    const double sharpness = e.first / e.second / turn;
    if (sharpness <= p.cylinder_border_ratio) pairs.emplace_back(sharpness, k.first, k.second);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

/// Refinement (curved surfaces, our addition; docs/detectors.md refinement 10): growth cuts a silo
/// or a curved facade into planar pieces about two angle thresholds wide. Two adjacent regions with
/// at least coplanar_min_faces faces each join when (a) their border is smooth: the length-weighted
/// mean angle between the units facing each other across it is at most cylinder_border_ratio of
/// the angle between the two regions' normals (on a curved surface the turn is spread over the
/// pieces; at a wall/roof crease it all happens at the border), and (b) their union is a cylinder: the
/// area-weighted unit normals are perpendicular to one axis (smallest eigenvalue of their scatter
/// matrix at most sin^2(cylinder_axis_angle)) and the face centroids, projected along that axis,
/// lie on a circle (Kasa fit) with RMS distance at most cylinder_max_rms mean edge lengths, and at
/// most the pooled RMS residual of the two parts about their own planes (the cylinder explains the
/// union better than two planes), with a radius of at most cylinder_max_radius mean edge lengths. Smoothest border first (lowest ratio); the union is
/// refitted after every join, so a flat facade next to a rounded corner (not a circle) stays apart.
void group_cylinders(const Units& U, const Params& p, std::vector<int>& region, int& n, json& rep) {
  const UnitGraph& g = U.g;
  const RegionSet rs = aggregate(U, region, n);
  std::vector<Vec3> un(static_cast<size_t>(g.num_units));
  for (int u = 0; u < g.num_units; ++u) un[static_cast<size_t>(u)] = unit_normal(U, u, p);
  // Per region: faces, normal scatter (sum of area * n n^T over its units), area.
  std::vector<std::vector<int>> faces(static_cast<size_t>(n));
  for (size_t f = 0; f < g.face_unit.size(); ++f)
    if (g.face_unit[f] >= 0) faces[static_cast<size_t>(region[static_cast<size_t>(g.face_unit[f])])].push_back(static_cast<int>(f));
  std::vector<Eigen::Matrix3d> scatter(static_cast<size_t>(n), Eigen::Matrix3d::Zero());
  std::vector<double> area(static_cast<size_t>(n), 0.0);
  for (int u = 0; u < g.num_units; ++u) {
    const size_t r = static_cast<size_t>(region[static_cast<size_t>(u)]);
    const double a = g.moments[static_cast<size_t>(u)].area;
    scatter[r] += a * un[static_cast<size_t>(u)] * un[static_cast<size_t>(u)].transpose();
    area[r] += a;
  }
  // Smooth borders between large regions, smoothest first.
  const std::vector<std::tuple<double, int, int>> pairs = smooth_border_pairs(U, p, region, rs, un);
  const double max_axis = std::pow(std::sin(p.cylinder_axis_angle), 2);
  std::vector<PlaneMoments> m = rs.m;
  size_t joins = 0, rej_axis = 0, rej_circle = 0;
  UnionFind uf(static_cast<size_t>(n));
  for (const auto& [ang, a0, b0] : pairs) {
    int a = uf.find(a0), b = uf.find(b0);
    if (a == b) continue;
    const Eigen::Matrix3d S = (scatter[static_cast<size_t>(a)] + scatter[static_cast<size_t>(b)]) /
                              (area[static_cast<size_t>(a)] + area[static_cast<size_t>(b)]);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(S);
    if (!(es.eigenvalues()[0] <= max_axis)) {
      ++rej_axis;
      continue;
    }
    std::vector<int> all = faces[static_cast<size_t>(a)];
    all.insert(all.end(), faces[static_cast<size_t>(b)].begin(), faces[static_cast<size_t>(b)].end());
    const CircleFit c = fit_circle(all, U, es.eigenvectors().col(0).normalized());
    // The cylinder must explain the union at least as well as the two parts' own planes explain
    // them (pooled RMS residual): true on a curved surface, false for a flat facade and the
    // rounded corner next to it, which are each flatter than any circle through both.
    const PlaneFit fa = fit_plane(m[static_cast<size_t>(a)]), fb = fit_plane(m[static_cast<size_t>(b)]);
    const double planes_rms = std::sqrt((m[static_cast<size_t>(a)].area * fa.eigenvalues[0] + m[static_cast<size_t>(b)].area * fb.eigenvalues[0]) /
                                        (m[static_cast<size_t>(a)].area + m[static_cast<size_t>(b)].area));
    if (!(c.rms <= p.cylinder_max_rms * p.edge) || !(c.rms <= planes_rms) || !(c.radius <= p.cylinder_max_radius * p.edge)) {
      ++rej_circle;
      continue;
    }
    if (faces[static_cast<size_t>(a)].size() < faces[static_cast<size_t>(b)].size()) std::swap(a, b);
    uf.p[static_cast<size_t>(b)] = a;
    faces[static_cast<size_t>(a)] = std::move(all);
    faces[static_cast<size_t>(b)].clear();
    scatter[static_cast<size_t>(a)] += scatter[static_cast<size_t>(b)];
    area[static_cast<size_t>(a)] += area[static_cast<size_t>(b)];
    m[static_cast<size_t>(a)].add(m[static_cast<size_t>(b)]);
    ++joins;
  }
  for (int& r : region) r = uf.find(r);
  n = compact_labels(region);
  rep["cylinder_joins"] = joins;
  rep["cylinder_rejections"] = {{"axis", rej_axis}, {"circle", rej_circle}};
}

class RegionGrowingDetector final : public Detector {
 public:
  void set_options(const Options& o) override {
    Stage::set_options(o);
    check_region_output_options(kName, o);
  }
  static StageInfo info() {
    StageInfo i;
    i.name = kName;
    i.kind = StageKind::Detector;
    i.description = "Planar regions by patch-based region growing with the Comprehensive Planarity Index (Liu et al. 2024)";
    i.doc = "docs/detectors.md";
    i.options = {
        opt_double("angle_threshold_deg", 25, "A unit joins a region only when its normal is within this angle of the region's fitted normal").range(0, 90).unit("deg"),
        opt_double("cpi_min", 0.6, "Minimum Comprehensive Planarity Index of a joining unit").range(0, 1),
        opt_double("w_flatness", 0.4, "CPI weight w1 of the flatness term 1 - s1/s2").range(0, 1),
        opt_double("w_compactness", 0.3, "CPI weight w2 of the compactness term s2/s3").range(0, 1),
        opt_double("w_normal", 0.3, "CPI weight w3 of the normal-consistency term 1 - sin(theta)").range(0, 1),
        opt_int("normal_smoothing_iterations", 5, "Bilateral filter passes over the face normals before units are judged (0 = raw normals)").range(0, 100),
        opt_double("normal_smoothing_sigma_deg", 30, "Width of the bilateral filter's similarity weight: neighbours at larger angles count little").range(1, 180).unit("deg"),
        opt_int("fit_min_faces", 8, "Units and regions with fewer faces are judged by their area-weighted filtered normal instead of their covariance fit").range(1, 1000000),
        opt_bool("split_nonplanar_patches", true, "Split a chart whose faces form several normal clusters (a chart wrapping a building corner) into one unit per cluster"),
        opt_double("split_min_fraction", 0.15, "A chart is split only when at least two of its normal clusters each hold this fraction of its area").range(0, 0.5),
        opt_bool("elongated_strips", true, "Refinement: dissolve strip-shaped regions into the neighbours whose plane their units fit"),
        opt_double("strip_compactness", 0.04, "A region is a strip when s2/s3 of its points is below this (0.04: length over 5 times the width)").range(0, 1),
        opt_double("strip_max_angle_deg", 40, "A strip's unit joins a neighbouring region only when their normals are within this angle (a ledge or beam goes to its facade; a narrow roof never joins a wall)").range(0, 90).unit("deg"),
        opt_bool("curved_components", true, "Refinement: group adjacent small regions joined by a smooth border into one component"),
        opt_double("curved_max_area_fraction", 0.02, "Small region / component: area under this fraction of the textured area").range(0, 1),
        opt_double("curved_border_angle_deg", 20, "A border is smooth when the mean angle between the units facing each other across it is below this").range(0, 90).unit("deg"),
        opt_bool("jagged_borders", true, "Refinement: regions with fewer than min_region_faces faces join the neighbouring region whose plane they fit, preferring more faces"),
        opt_int("min_region_faces", 12, "Regions smaller than this are absorbed by the jagged-border refinement when they fit a neighbour's plane").range(1, 1000000),
        opt_double("max_plane_distance", 1.0, "Fit to a neighbour's plane (refinements): RMS distance at most this many mean edge lengths").range(0, 1000),
        opt_int("tiny_region_faces", 3, "Regions with at most this many faces that fit no neighbour join the neighbour with the most faces").range(0, 1000000),
        opt_bool("absorb_enclosed", true, "Refinement: a small region enclosed by one neighbouring region (a balcony or window reveal inside its facade) joins it whatever its angle"),
        opt_double("enclosed_max_fraction", 0.1, "An enclosed region joins only when it has fewer than this fraction of the enclosing region's faces").range(0, 1),
        opt_double("enclosed_border_fraction", 0.75, "Enclosed: at least this fraction of the region's border (shared edges plus open mesh edges, 3D length) is shared with one region").range(0.5, 1),
        opt_bool("coplanar_grouping", true, "Refinement: join coplanar regions (adjacent or separated by a smaller region) and let small regions lying on a large neighbour's plane join it"),
        opt_double("coplanar_angle_deg", 20, "Coplanar grouping: fitted normals of the two regions within this angle").range(0, 90).unit("deg"),
        opt_double("coplanar_max_offset", 0.25, "Coplanar grouping: each region's offset from the union's plane (RMS distance beyond its own residual: tilt and shift) at most this many mean edge lengths; a parallel step larger than this stays apart").range(0, 1000),
        opt_double("coplanar_max_rms", 0.5, "Coplanar grouping: RMS residual of the union's plane fit at most this many mean edge lengths").range(0, 1000),
        opt_int("coplanar_min_faces", 12, "Coplanar grouping: regions with at least this many faces are grouped; smaller ones are speckle").range(1, 1000000),
        opt_double("coplanar_min_coherence", 0.5, "Coplanar grouping and curved surfaces: a region takes part only when its face normals agree: |sum of area-weighted face normals| / area at least this (trees and clutter do not)").range(0, 1),
        opt_double("speckle_max_distance", 0.5, "Coplanar grouping: a speckle region joins a large neighbour when the RMS distance of its surface to that plane is at most this many mean edge lengths (the nearest such plane)").range(0, 1000),
        opt_double("speckle_max_fraction", 0.3, "Coplanar grouping: a speckle region joins only a neighbour with more than 1/this times its faces (a plane fitted well enough to judge it)").range(0, 1),
        opt_double("speckle_angle_deg", 45, "Coplanar grouping: a speckle region joins a large neighbour's plane only when their normals are within this angle (never across a wall/roof crease)").range(0, 90).unit("deg"),
        opt_bool("curved_surfaces", true, "Refinement: adjacent regions with a smooth border whose union is a cylinder (a silo, a curved facade cut into planar pieces) join"),
        opt_double("cylinder_border_ratio", 0.6, "Curved surfaces: the border must be smooth: mean angle between the units facing each other across it at most this fraction of the angle between the two regions' normals (a crease turns all at once: ~1)").range(0, 1),
        opt_double("cylinder_axis_angle_deg", 15, "Curved surfaces: the union's unit normals must be within this angle of perpendicular to one axis (RMS)").range(0, 90).unit("deg"),
        opt_double("cylinder_max_rms", 0.5, "Curved surfaces: RMS distance of the union's face centroids to the fitted circle at most this many mean edge lengths").range(0, 1000),
        opt_double("cylinder_max_radius", 50, "Curved surfaces: fitted radius at most this many mean edge lengths (a gently bent plane is left to the planar rules)").range(0, 1000000),
    };
    for (OptionSpec& o : output_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<RegionGrowingDetector>(); };
    return i;
  }

  void detect(StageContext& ctx) override {
    if (!ctx.mesh || !ctx.topology || !ctx.input_charts || !ctx.report)
      throw StageError(std::string(kName) + ": needs the mesh, its topology, its charts and a report node");
    Params p = read_params(options());
    json& rep = *ctx.report;
    ctx.step(kName, 0.0);
    p.edge = mean_edge_length(*ctx.mesh, *ctx.topology);
    rep["mean_edge_length"] = p.edge;
    const std::vector<Vec3> fn = filter_face_normals(*ctx.mesh, *ctx.topology, p.smoothing_iterations, p.smoothing_sigma);
    ctx.step(kName, 0.1);
    int nu = 0;
    std::vector<int> face_unit = make_units(ctx, p, fn, nu, rep);
    ctx.step(kName, 0.2);
    Units U;
    U.g = build_unit_graph(*ctx.mesh, *ctx.topology, std::move(face_unit), nu, reference_point(*ctx.mesh));
    U.smooth.assign(static_cast<size_t>(nu), Vec3::Zero());
    for (size_t f = 0; f < fn.size(); ++f)
      if (U.g.face_unit[f] >= 0) U.smooth[static_cast<size_t>(U.g.face_unit[f])] += face_area_3d(*ctx.mesh, f) * fn[f];
    U.open = open_border_lengths(*ctx.mesh, *ctx.topology, U.g);
    if (p.cylinders) {
      const Vec3 ref = reference_point(*ctx.mesh);
      U.face_centroid.resize(fn.size());
      U.face_area.resize(fn.size());
      for (size_t f = 0; f < fn.size(); ++f) {
        U.face_centroid[f] = (ctx.mesh->corner_position(f, 0) + ctx.mesh->corner_position(f, 1) + ctx.mesh->corner_position(f, 2)) / 3.0 - ref;
        U.face_area[f] = face_area_3d(*ctx.mesh, f);
      }
    }
    rep["units"] = nu;
    ctx.step(kName, 0.4);
    int n = 0;
    std::vector<int> region = grow(U, p, n, rep);
    place_zero_area_units(U.g, region, n, rep);
    n = compact_labels(region);
    ctx.step(kName, 0.7);
    if (p.strips) dissolve_strips(U, p, region, n, rep);
    if (p.curved) group_curved(U, p, region, n, rep);
    if (p.jagged) absorb_small(U, p, region, n, rep);
    if (p.coplanar) group_coplanar(U, p, region, n, rep);
    if (p.cylinders) group_cylinders(U, p, region, n, rep);
    if (p.enclosed) absorb_enclosed(U, p, region, n, rep);
    ctx.step(kName, 0.9);
    std::vector<int> face_label(ctx.mesh->faces.size(), -1);
    for (size_t f = 0; f < face_label.size(); ++f)
      if (U.g.face_unit[f] >= 0) face_label[f] = region[static_cast<size_t>(U.g.face_unit[f])];
    ctx.regions = regions_from_labels(face_label);
    ctx.regions.planarity_weights = std::array<double, 3>{p.w.flatness, p.w.compactness, p.w.normal};
    report_region_stats(ctx.regions, rep);
    write_region_outputs(kName, options(), ctx);
    ctx.step(kName, 1.0);
  }
};

}  // namespace
}  // namespace texdefrag::detectors

TEXDEFRAG_PLUGIN(texdefrag::detectors::RegionGrowingDetector)
