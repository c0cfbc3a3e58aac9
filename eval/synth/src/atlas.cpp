// Texture atlas of the synthetic buildings, the way photogrammetry exports build theirs: a chart
// is a connected set of faces with the same view; its UVs are the perspective projection of its
// vertices into that camera, scaled to the camera's atlas resolution; charts are shelf-packed by
// height into pages with padding; each chart has its own copies of its vertices. Colours are
// procedural (facades, windows, roofs, ground) seen through each camera's exposure and colour gain,
// rasterised per chart, and the padding is filled by dilation so seams bleed as in real atlases.
#include "internal.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

namespace texdefrag::synth::detail {
namespace {

int find(std::vector<int>& parent, int x) {
  while (parent[static_cast<size_t>(x)] != x) {
    parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    x = parent[static_cast<size_t>(x)];
  }
  return x;
}

/// Procedural albedo (0-255 per channel) of a surface point.
class Palette {
 public:
  Palette(const Shape& shape, Rng& rng) : shape_(shape) {
    static const double walls[][3] = {{214, 200, 170}, {232, 228, 218}, {190, 190, 186}, {168, 92, 70},
                                      {222, 206, 150}, {200, 178, 160}, {176, 186, 196}};
    const auto& w = walls[rng.uniform_int(0, 6)];
    wall_ = Vec3(w[0], w[1], w[2]);
    const bool tiles = shape.archetype == "residential";
    roof_ = tiles ? Vec3(rng.uniform(140, 180), rng.uniform(60, 90), rng.uniform(45, 65))
                  : Vec3(rng.uniform(120, 150), rng.uniform(128, 150), rng.uniform(135, 160));
    flat_ = Vec3::Constant(rng.uniform(150, 185));
    floor_h_ = rng.uniform(2.8, 3.3);
    salt_ = rng.next();
    tint_.resize(shape.planes.size());
    for (Vec3& t : tint_) t = Vec3(rng.uniform(0.94, 1.06), rng.uniform(0.94, 1.06), rng.uniform(0.94, 1.06));
  }

  Vec3 albedo(int plane, const Vec3& p) const {
    const PlaneInfo& pl = shape_.planes[static_cast<size_t>(plane)];
    const double n1 = value_noise(p, 0.7, salt_), n2 = value_noise(p, 3.0, salt_ + 1);
    Vec3 c;
    switch (pl.semantic) {
      case SemanticClass::Ground:
        c = n2 > 0.62 ? Vec3(70, 110, 50) : Vec3(100, 100, 104);
        c *= 0.85 + 0.3 * n1;
        break;
      case SemanticClass::Roof:
        if (pl.normal.z() > 0.99) {
          c = flat_ * (0.8 + 0.3 * n1);
        } else {
          const double stripe = std::fmod(std::abs(p.z()) / 0.25, 1.0) < 0.2 ? 0.8 : 1.0;
          c = roof_ * stripe * (0.85 + 0.25 * n1);
        }
        break;
      case SemanticClass::Wall: {
        c = wall_.cwiseProduct(tint_[static_cast<size_t>(plane)]) * (0.88 + 0.2 * n1);
        if (std::fmod(p.z(), floor_h_) < 0.15) c *= 0.85;  // floor slab line
        c *= 1.0 - 0.12 * std::exp(-p.z());                // splash dirt at the foot
        break;
      }
      case SemanticClass::Vegetation:
        c = Vec3(55 + 40 * n2, 85 + 50 * n1, 40) * (0.7 + 0.5 * n1);
        break;
      case SemanticClass::Detail:
        if (shape_.plane_glass[static_cast<size_t>(plane)])
          c = Vec3(45, 60, 78) * (0.7 + 0.8 * n1);
        else
          c = Vec3(175, 172, 168) * (0.8 + 0.3 * n1);
        break;
    }
    return c;
  }
  uint64_t salt() const { return salt_; }

 private:
  const Shape& shape_;
  Vec3 wall_, roof_, flat_;
  double floor_h_ = 3;
  uint64_t salt_ = 0;
  std::vector<Vec3> tint_;
};

uint8_t to_byte(double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

int next_pow2(int v) {
  int p = 32;
  while (p < v) p *= 2;
  return p;
}

/// A chart of the generated atlas.
struct Chart {
  std::vector<int> verts;  ///< raw vertex ids
  std::vector<Vec2> uv;    ///< texels, relative to the chart's lower-left corner after packing
  double w = 0, h = 0;
  int page = 0;
  Vec2 at = Vec2::Zero();
  bool mirrored = false;   ///< mirror_fraction: u -> -u
  int host = -1;           ///< overlap_fraction: the chart this one is laid over
  double exposure = 1;     ///< exposure_sd: the chart's own brightness factor
};

/// Marks charts mirrored, in random order, until `fraction` of the F faces are in mirrored charts
/// (a chart is taken when that brings the count closer to the target).
void choose_mirrored(const std::vector<std::vector<int>>& chart_faces, double fraction, size_t F, Rng& rng,
                     std::vector<Chart>& charts) {
  if (fraction <= 0) return;
  std::vector<size_t> order(charts.size());
  std::iota(order.begin(), order.end(), size_t{0});
  for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[static_cast<size_t>(rng.uniform_int(0, static_cast<int>(i) - 1))]);
  const double target = fraction * static_cast<double>(F);
  double taken = 0;
  for (size_t c : order) {
    const double n = static_cast<double>(chart_faces[c].size());
    if (taken + 0.5 * n > target) continue;
    charts[c].mirrored = true;
    taken += n;
  }
}

/// Mirrors (u -> -u), scales by a log-normal density factor and warps a chart's texel
/// coordinates by a homography t -> c + (t - c) / (1 + g d.(t - c) / e) (d a random unit
/// direction, e twice the largest |d.(t - c)|: the denominator stays in [1 - g/2, 1 + g/2] > 0,
/// so no triangle flips; density ratio (1 + g/2) / (1 - g/2) across the chart).
void distort_chart(std::vector<Vec2>& uv, bool mirrored, const SynthOptions& o, Rng& rng) {
  if (mirrored)
    for (Vec2& t : uv) t.x() = -t.x();
  if (o.density_jitter > 0) {
    const double k = std::exp(o.density_jitter * rng.normal());
    for (Vec2& t : uv) t *= k;
  }
  if (o.perspective > 0 && !uv.empty()) {
    const double a = rng.uniform(0, 6.283185307179586);
    const Vec2 d(std::cos(a), std::sin(a));
    Vec2 c = Vec2::Zero();
    for (const Vec2& t : uv) c += t;
    c /= static_cast<double>(uv.size());
    double e = 0;
    for (const Vec2& t : uv) e = std::max(e, std::abs(d.dot(t - c)));
    if (e <= 0) return;
    for (Vec2& t : uv) t = c + (t - c) / (1 + o.perspective * d.dot(t - c) / (2 * e));
  }
}

/// Picks round(fraction * charts) guests, each laid over a random larger chart (host) that is
/// not itself a guest; a guest without a host after 32 draws stays where it is.
void choose_hosts(std::vector<Chart>& charts, double fraction, Rng& rng) {
  const int C = static_cast<int>(charts.size());
  const int n = static_cast<int>(std::lround(fraction * C));
  if (n <= 0 || C < 2) return;
  std::vector<uint8_t> guest(charts.size(), 0), host(charts.size(), 0);
  for (int i = 0, tries = 0; i < n && tries < 20 * n; ++tries) {
    const int g = rng.uniform_int(0, C - 1);
    if (guest[static_cast<size_t>(g)]) continue;
    for (int k = 0; k < 32; ++k) {
      const int h = rng.uniform_int(0, C - 1);
      const Chart& H = charts[static_cast<size_t>(h)];
      // a host keeps its place: never also a guest
      if (h == g || guest[static_cast<size_t>(h)] || host[static_cast<size_t>(g)]) continue;
      if (H.w < charts[static_cast<size_t>(g)].w || H.h < charts[static_cast<size_t>(g)].h) continue;
      charts[static_cast<size_t>(g)].host = h;
      guest[static_cast<size_t>(g)] = 1;
      host[static_cast<size_t>(h)] = 1;
      ++i;
      break;
    }
  }
}

/// Counts clutter faces into the truth.
void count_features(const RawMesh& raw, const Shape& shape, SynthTruth& t) {
  (void)raw;
  t.clutter_faces = 0;
  for (int p : t.face_plane)
    if (shape.clutter_planes_from >= 0 && p >= shape.clutter_planes_from) ++t.clutter_faces;
}


// build_atlas's steps, in order. `hard` is the hard features' own random stream; its draws happen
// in the same order as before the split, so the same seed gives the same files.

/// Per face: 1 when its view's camera sees it from behind (n . (camera - centroid) < 0). Only faces
/// that no camera sees from the front get such a view (select_views' fallback: undersides of eaves
/// and balconies, which an aerial flight never sees and real photogrammetry does not reconstruct).
std::vector<uint8_t> seen_from_behind(const RawMesh& raw, const std::vector<int>& views, const std::vector<Camera>& cams) {
  std::vector<uint8_t> behind(raw.tris.size(), 0);
  for (size_t f = 0; f < raw.tris.size(); ++f) {
    const Vec3& a = raw.positions[static_cast<size_t>(raw.tris[f][0])];
    const Vec3& b = raw.positions[static_cast<size_t>(raw.tris[f][1])];
    const Vec3& c = raw.positions[static_cast<size_t>(raw.tris[f][2])];
    const Vec3 n = (b - a).cross(c - a);
    behind[f] = n.dot(cams[static_cast<size_t>(views[f])].position - (a + b + c) / 3.0) < 0 ? 1 : 0;
  }
  return behind;
}

/// Step 1: charts are faces joined across shared edges when they have the same view and are seen
/// from the same side of it (seen_from_behind: such faces make charts of their own). Returns each
/// chart's faces, charts numbered in order of their first face; counts into `truth` the edges
/// between faces of two planes (plane_edges) and those of them inside one chart.
std::vector<std::vector<int>> join_charts(const RawMesh& raw, const std::vector<int>& views,
                                         const std::vector<uint8_t>& behind, SynthTruth& truth) {
  const size_t F = raw.tris.size();
  std::vector<int> parent(F);
  std::iota(parent.begin(), parent.end(), 0);
  {
    std::unordered_map<uint64_t, std::vector<int>> edge_faces;
    edge_faces.reserve(F * 2);
    for (size_t f = 0; f < F; ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = raw.tris[f][static_cast<size_t>(k)], b = raw.tris[f][static_cast<size_t>((k + 1) % 3)];
        edge_faces[(static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint64_t>(std::max(a, b))].push_back(static_cast<int>(f));
      }
    for (size_t f = 0; f < F; ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = raw.tris[f][static_cast<size_t>(k)], b = raw.tris[f][static_cast<size_t>((k + 1) % 3)];
        for (int g : edge_faces[(static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint64_t>(std::max(a, b))])
          if (views[static_cast<size_t>(g)] == views[f] && behind[static_cast<size_t>(g)] == behind[f])
            parent[static_cast<size_t>(find(parent, g))] = find(parent, static_cast<int>(f));
      }
    // charts across planes: edges between faces of two planes that lie inside one chart
    truth.plane_edges = truth.plane_edges_in_chart = 0;
    for (const auto& [key, fs] : edge_faces)
      if (fs.size() == 2 && raw.face_plane[static_cast<size_t>(fs[0])] != raw.face_plane[static_cast<size_t>(fs[1])]) {
        ++truth.plane_edges;
        if (find(parent, fs[0]) == find(parent, fs[1])) ++truth.plane_edges_in_chart;
      }
  }
  std::vector<int> root_chart(F, -1);
  std::vector<std::vector<int>> chart_faces;
  for (size_t f = 0; f < F; ++f) {
    const int r = find(parent, static_cast<int>(f));
    if (root_chart[static_cast<size_t>(r)] < 0) {
      root_chart[static_cast<size_t>(r)] = static_cast<int>(chart_faces.size());
      chart_faces.emplace_back();
    }
    chart_faces[static_cast<size_t>(root_chart[static_cast<size_t>(r)])].push_back(static_cast<int>(f));
  }
  return chart_faces;
}

/// Step 2: per chart, its local vertices and their texel coordinates (y up) in the camera of its
/// first face's view, mirrored, distorted and given an exposure as the options say, then scaled
/// down to fit a page when larger; finally guests are laid over hosts (overlap_fraction).
std::vector<Chart> make_charts(const RawMesh& raw, const std::vector<std::vector<int>>& chart_faces,
                               const std::vector<int>& views, const std::vector<uint8_t>& behind,
                               const std::vector<Camera>& cams, const SynthOptions& options, Rng& hard) {
  const size_t C = chart_faces.size();
  std::vector<Chart> charts(C);
  choose_mirrored(chart_faces, options.mirror_fraction, raw.tris.size(), hard, charts);
  std::unordered_map<int, int> local;
  for (size_t c = 0; c < C; ++c) {
    Chart& ch = charts[c];
    const Camera& cam = cams[static_cast<size_t>(views[static_cast<size_t>(chart_faces[c][0])])];
    local.clear();
    for (int f : chart_faces[c])
      for (int v : raw.tris[static_cast<size_t>(f)])
        if (local.emplace(v, static_cast<int>(ch.verts.size())).second) ch.verts.push_back(v);
    for (int v : ch.verts) {
      Vec2 px;
      if (!project(cam, raw.positions[static_cast<size_t>(v)], px))
        throw std::logic_error("synth: chart vertex behind its camera");
      ch.uv.emplace_back(px.x() * cam.texel_scale, -px.y() * cam.texel_scale);
    }
    // note: a chart seen from behind is mirrored back, so that its UVs turn like the 3D winding as
    // every real producer's do (a projection from behind would reverse them: an input fold).
    distort_chart(ch.uv, ch.mirrored != (behind[static_cast<size_t>(chart_faces[c][0])] != 0), options, hard);
    if (options.exposure_sd > 0) ch.exposure = std::clamp(1 + options.exposure_sd * hard.normal(), 0.5, 1.5);
    Vec2 lo(1e300, 1e300), hi(-1e300, -1e300);
    for (const Vec2& t : ch.uv) {
      lo = lo.cwiseMin(t);
      hi = hi.cwiseMax(t);
    }
    double w = hi.x() - lo.x(), h = hi.y() - lo.y();
    const double fit = (options.page_size - 2.0 * options.padding - 2) / std::max(w, h);
    const double s = fit < 1 ? fit : 1.0;  // a chart larger than a page is scaled down to fit
    for (Vec2& t : ch.uv) t = (t - lo) * s;
    ch.w = w * s;
    ch.h = h * s;
  }
  choose_hosts(charts, options.overlap_fraction, hard);
  return charts;
}

/// The charts' placement: packing order (tallest first), pages, each page's used extent (texels).
struct Packing {
  std::vector<int> order;
  std::vector<Vec2> used;
  int num_pages = 1;
};

/// Step 3: shelf packing of the charts that are not guests, tallest first, `padding` texels
/// around each, on pages of page_size; a guest takes its host's page at a random offset inside it.
Packing shelf_pack(std::vector<Chart>& charts, const SynthOptions& options, Rng& hard) {
  Packing pk;
  pk.order.resize(charts.size());
  std::iota(pk.order.begin(), pk.order.end(), 0);
  std::stable_sort(pk.order.begin(), pk.order.end(), [&](int a, int b) {
    return std::ceil(charts[static_cast<size_t>(a)].h) > std::ceil(charts[static_cast<size_t>(b)].h);
  });
  const int P = options.page_size, pad = options.padding;
  int page = 0, x = 0, y = 0, shelf = 0;
  pk.used.assign(1, Vec2::Zero());
  for (int id : pk.order) {
    Chart& ch = charts[static_cast<size_t>(id)];
    if (ch.host >= 0) continue;  // laid over its host below
    const int cw = static_cast<int>(std::ceil(ch.w)) + 2 * pad + 1, chh = static_cast<int>(std::ceil(ch.h)) + 2 * pad + 1;
    if (x + cw > P) {
      x = 0;
      y += shelf;
      shelf = 0;
    }
    if (y + chh > P) {
      ++page;
      pk.used.emplace_back(0, 0);
      x = y = shelf = 0;
    }
    ch.page = page;
    ch.at = Vec2(x + pad, y + pad);
    x += cw;
    shelf = std::max(shelf, chh);
    pk.used[static_cast<size_t>(page)] = pk.used[static_cast<size_t>(page)].cwiseMax(Vec2(x, y + chh));
  }
  pk.num_pages = page + 1;
  for (Chart& ch : charts) {
    if (ch.host < 0) continue;
    const Chart& host = charts[static_cast<size_t>(ch.host)];
    ch.page = host.page;
    ch.at = host.at + Vec2(std::floor(hard.uniform(0, host.w - ch.w)), std::floor(hard.uniform(0, host.h - ch.h)));
  }
  return pk;
}

/// Step 4a: one material and page per packed page (`<name>_<k>.jpg`); full pages keep page_size,
/// the last one is trimmed to the power of two covering its charts.
void add_pages(TexturedMesh& mesh, const std::string& name, const Packing& pk, int page_size) {
  const int P = page_size;
  for (int k = 0; k < pk.num_pages; ++k) {
    Material m;
    m.name = "material_" + std::to_string(k);
    m.extra_lines = {"Ka 1 1 1", "Kd 1 1 1", "Ks 0 0 0", "Ns 0"};
    m.map_kd = name + "_" + std::to_string(k) + ".jpg";
    mesh.materials.push_back(m);
    Page pg;
    pg.material = m.name;
    pg.image_path = m.map_kd;
    // full pages stay full; the last one is trimmed to the power of two covering its charts
    pg.width = k + 1 < pk.num_pages ? P : std::min(P, next_pow2(static_cast<int>(pk.used[static_cast<size_t>(k)].x())));
    pg.height = k + 1 < pk.num_pages ? P : std::min(P, next_pow2(static_cast<int>(pk.used[static_cast<size_t>(k)].y())));
    mesh.pages.push_back(pg);
  }
}

/// Step 4b: the charts' vertices, texture coordinates and faces, grouped by page then packing
/// order (zero_uv_fraction of the faces get three coincident texture coordinates of their own),
/// and the truth of every face in that order (plane, class, view, chart, mirrored, zero UV), the
/// chart count, the overlapping chart pairs and the charts' exposures.
void add_faces(const RawMesh& raw, const Shape& shape, const std::vector<int>& views,
               const std::vector<std::vector<int>>& chart_faces, const std::vector<Chart>& charts,
               const std::vector<int>& order, const SynthOptions& options, Rng& hard, TexturedMesh& mesh,
               SynthTruth& truth) {
  const size_t C = charts.size();
  std::vector<int> page_order = order;
  std::stable_sort(page_order.begin(), page_order.end(), [&](int a, int b) {
    return charts[static_cast<size_t>(a)].page < charts[static_cast<size_t>(b)].page;
  });
  truth.face_plane.clear();
  truth.face_class.clear();
  truth.face_view.clear();
  truth.face_chart.clear();
  truth.face_mirrored.clear();
  truth.face_zero_uv.clear();
  truth.overlapping_charts.clear();
  std::vector<int> chart_no_of(C, -1);
  std::vector<double> chart_exposure;
  std::unordered_map<int, int> local;
  int chart_no = 0;
  for (int id : page_order) {
    const Chart& ch = charts[static_cast<size_t>(id)];
    const Page& pg = mesh.pages[static_cast<size_t>(ch.page)];
    const int base = static_cast<int>(mesh.positions.size()), tbase = static_cast<int>(mesh.texcoords.size());
    for (size_t i = 0; i < ch.verts.size(); ++i) {
      mesh.positions.push_back(raw.positions[static_cast<size_t>(ch.verts[i])]);
      const Vec2 t = ch.at + ch.uv[i];
      mesh.texcoords.emplace_back(t.x() / pg.width, t.y() / pg.height);
    }
    local.clear();
    for (size_t i = 0; i < ch.verts.size(); ++i) local.emplace(ch.verts[i], static_cast<int>(i));
    chart_no_of[static_cast<size_t>(id)] = chart_no;
    chart_exposure.push_back(ch.exposure);
    for (int f : chart_faces[static_cast<size_t>(id)]) {
      Face fc;
      for (int k = 0; k < 3; ++k) {
        const int li = local[raw.tris[static_cast<size_t>(f)][static_cast<size_t>(k)]];
        fc.v[static_cast<size_t>(k)] = base + li;
        fc.vt[static_cast<size_t>(k)] = tbase + li;
      }
      // zero UV area: the face gets its own texture coordinates, all at its first corner's UV
      const bool zero = options.zero_uv_fraction > 0 && hard.chance(options.zero_uv_fraction);
      if (zero) {
        const Vec2 t0 = mesh.texcoords[static_cast<size_t>(fc.vt[0])];
        for (int k = 0; k < 3; ++k) {
          fc.vt[static_cast<size_t>(k)] = static_cast<int>(mesh.texcoords.size());
          mesh.texcoords.push_back(t0);
        }
      }
      fc.material = ch.page;
      fc.page = ch.page;
      fc.source_line = 0;
      mesh.faces.push_back(fc);
      const int pl = raw.face_plane[static_cast<size_t>(f)];
      truth.face_plane.push_back(pl);
      truth.face_class.push_back(shape.planes[static_cast<size_t>(pl)].semantic);
      truth.face_view.push_back(views[static_cast<size_t>(f)]);
      truth.face_chart.push_back(chart_no);
      truth.face_mirrored.push_back(ch.mirrored ? 1 : 0);
      truth.face_zero_uv.push_back(zero ? 1 : 0);
    }
    ++chart_no;
  }
  truth.num_charts = chart_no;
  for (size_t c = 0; c < C; ++c)
    if (charts[c].host >= 0)
      truth.overlapping_charts.push_back({chart_no_of[c], chart_no_of[static_cast<size_t>(charts[c].host)]});
  truth.chart_exposure = chart_exposure;
}

/// Step 5a: paints every face's texels (centres inside it, with a small tolerance that closes
/// cracks) with its plane's albedo at the point, times its camera's exposure and colour gain and
/// its chart's exposure, plus a per-texel grain. Returns per page the mask of painted texels.
std::vector<std::vector<uint8_t>> paint_faces(SynthModel& model, const Palette& palette) {
  const TexturedMesh& mesh = model.mesh;
  const SynthTruth& truth = model.truth;
  const std::vector<Camera>& cams = truth.cameras;
  std::vector<std::vector<uint8_t>> filled(model.pages.size());
  for (size_t k = 0; k < model.pages.size(); ++k)
    filled[k].assign(static_cast<size_t>(model.pages[k].width) * static_cast<size_t>(model.pages[k].height), 0);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& fc = mesh.faces[f];
    Image& img = model.pages[static_cast<size_t>(fc.page)];
    std::vector<uint8_t>& mask = filled[static_cast<size_t>(fc.page)];
    const Camera& cam = cams[static_cast<size_t>(truth.face_view[f])];
    Vec2 t[3];
    Vec3 p[3];
    for (int k = 0; k < 3; ++k) {
      t[k] = mesh.corner_texel(f, k);
      p[k] = mesh.corner_position(f, k);
    }
    const double area = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x();
    if (std::abs(area) < 1e-12) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].x(), t[1].x(), t[2].x()}))));
    const int x1 = std::min(img.width - 1, static_cast<int>(std::floor(std::max({t[0].x(), t[1].x(), t[2].x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].y(), t[1].y(), t[2].y()}))));
    const int y1 = std::min(img.height - 1, static_cast<int>(std::floor(std::max({t[0].y(), t[1].y(), t[2].y()}))));
    const double tol = -0.02;  // slightly outside: closes cracks between a chart's triangles
    for (int yy = y0; yy <= y1; ++yy)
      for (int xx = x0; xx <= x1; ++xx) {
        const Vec2 q(xx + 0.5, yy + 0.5);
        double b[3];
        for (int k = 0; k < 3; ++k) {
          const Vec2& a = t[(k + 1) % 3];
          const Vec2& c = t[(k + 2) % 3];
          b[k] = ((c - a).x() * (q - a).y() - (c - a).y() * (q - a).x()) / area;  // barycentric weight of corner k
        }
        if (b[0] < tol || b[1] < tol || b[2] < tol) continue;
        const Vec3 pt = b[0] * p[0] + b[1] * p[1] + b[2] * p[2];
        const Vec3 alb = palette.albedo(truth.face_plane[f], pt);
        const int row = img.height - 1 - yy;
        const uint64_t hsh = Rng::mix(palette.salt() ^ (static_cast<uint64_t>(fc.page) << 48) ^
                                      (static_cast<uint64_t>(row) << 24) ^ static_cast<uint64_t>(xx));
        const double grain = (static_cast<double>(hsh & 0xFF) / 255.0 - 0.5) * 10.0;
        uint8_t* px = img.at(xx, row);
        const double expo = cam.exposure * truth.chart_exposure[static_cast<size_t>(truth.face_chart[f])];
        for (int ch = 0; ch < 3; ++ch) px[ch] = to_byte(alb[ch] * expo * cam.colour_gain[ch] + grain);
        mask[static_cast<size_t>(row) * static_cast<size_t>(img.width) + static_cast<size_t>(xx)] = 1;
      }
  }
  return filled;
}

/// Step 5b: dilates the painted texels into the padding: each of `passes` passes fills the empty
/// texels next to painted ones (8-neighbourhood) with their mean.
void dilate_into_padding(std::vector<Image>& pages, std::vector<std::vector<uint8_t>>& filled, int passes) {
  for (size_t k = 0; k < pages.size(); ++k) {
    Image& img = pages[k];
    std::vector<uint8_t>& mask = filled[k];
    for (int pass = 0; pass < passes; ++pass) {
      std::vector<uint8_t> next = mask;
      for (int yy = 0; yy < img.height; ++yy)
        for (int xx = 0; xx < img.width; ++xx) {
          if (mask[static_cast<size_t>(yy) * static_cast<size_t>(img.width) + static_cast<size_t>(xx)]) continue;
          int sum[3] = {0, 0, 0}, n = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int u = xx + dx, v = yy + dy;
              if (u < 0 || v < 0 || u >= img.width || v >= img.height) continue;
              if (!mask[static_cast<size_t>(v) * static_cast<size_t>(img.width) + static_cast<size_t>(u)]) continue;
              const uint8_t* q = img.at(u, v);
              for (int ch = 0; ch < 3; ++ch) sum[ch] += q[ch];
              ++n;
            }
          if (!n) continue;
          uint8_t* px = img.at(xx, yy);
          for (int ch = 0; ch < 3; ++ch) px[ch] = static_cast<uint8_t>(sum[ch] / n);
          next[static_cast<size_t>(yy) * static_cast<size_t>(img.width) + static_cast<size_t>(xx)] = 1;
        }
      mask.swap(next);
    }
  }
}

}  // namespace

void build_atlas(const RawMesh& raw, const Shape& shape, const std::vector<int>& views, const SynthOptions& options,
                 Rng& rng, SynthModel& model) {
  const std::vector<uint8_t> behind = seen_from_behind(raw, views, model.truth.cameras);
  const std::vector<std::vector<int>> chart_faces = join_charts(raw, views, behind, model.truth);
  Rng hard(options.seed, 0x4A5D);  // the hard features' own stream: default outputs unchanged
  std::vector<Chart> charts = make_charts(raw, chart_faces, views, behind, model.truth.cameras, options, hard);
  const Packing pk = shelf_pack(charts, options, hard);
  TexturedMesh& mesh = model.mesh;
  mesh = TexturedMesh();
  add_pages(mesh, model.name, pk, options.page_size);
  add_faces(raw, shape, views, chart_faces, charts, pk.order, options, hard, mesh, model.truth);
  count_features(raw, shape, model.truth);
  model.pages.assign(static_cast<size_t>(pk.num_pages), Image());
  for (int k = 0; k < pk.num_pages; ++k) {
    Image& img = model.pages[static_cast<size_t>(k)];
    img.width = mesh.pages[static_cast<size_t>(k)].width;
    img.height = mesh.pages[static_cast<size_t>(k)].height;
    img.channels = 3;
    img.pixels.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 0);
  }
  if (!options.render_pages) return;
  const Palette palette(shape, rng);
  std::vector<std::vector<uint8_t>> filled = paint_faces(model, palette);
  dilate_into_padding(model.pages, filled, options.padding + 1);
}

}  // namespace texdefrag::synth::detail
