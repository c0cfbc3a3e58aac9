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

}  // namespace

void build_atlas(const RawMesh& raw, const Shape& shape, const std::vector<int>& views, const SynthOptions& options,
                 Rng& rng, SynthModel& model) {
  const size_t F = raw.tris.size();
  const std::vector<Camera>& cams = model.truth.cameras;
  // 1. charts: faces joined across shared edges when they have the same view
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
          if (views[static_cast<size_t>(g)] == views[f]) parent[static_cast<size_t>(find(parent, g))] = find(parent, static_cast<int>(f));
      }
  }
  std::vector<int> chart_of(F), root_chart(F, -1);
  std::vector<std::vector<int>> chart_faces;
  for (size_t f = 0; f < F; ++f) {
    const int r = find(parent, static_cast<int>(f));
    if (root_chart[static_cast<size_t>(r)] < 0) {
      root_chart[static_cast<size_t>(r)] = static_cast<int>(chart_faces.size());
      chart_faces.emplace_back();
    }
    chart_of[f] = root_chart[static_cast<size_t>(r)];
    chart_faces[static_cast<size_t>(chart_of[f])].push_back(static_cast<int>(f));
  }
  const size_t C = chart_faces.size();
  // 2. per chart: local vertices and their texel coordinates (y up) in the chart's camera
  struct Chart {
    std::vector<int> verts;  ///< raw vertex ids
    std::vector<Vec2> uv;    ///< texels, relative to the chart's lower-left corner after packing
    double w = 0, h = 0;
    int page = 0;
    Vec2 at = Vec2::Zero();
  };
  std::vector<Chart> charts(C);
  std::unordered_map<int, int> local;
  for (size_t c = 0; c < C; ++c) {
    Chart& ch = charts[c];
    const Camera& cam = cams[static_cast<size_t>(views[static_cast<size_t>(chart_faces[c][0])])];
    local.clear();
    for (int f : chart_faces[c])
      for (int v : raw.tris[static_cast<size_t>(f)])
        if (local.emplace(v, static_cast<int>(ch.verts.size())).second) ch.verts.push_back(v);
    Vec2 lo(1e300, 1e300), hi(-1e300, -1e300);
    for (int v : ch.verts) {
      Vec2 px;
      if (!project(cam, raw.positions[static_cast<size_t>(v)], px))
        throw std::logic_error("synth: chart vertex behind its camera");
      const Vec2 t(px.x() * cam.texel_scale, -px.y() * cam.texel_scale);
      ch.uv.push_back(t);
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
  // 3. shelf packing, tallest first
  std::vector<int> order(C);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return std::ceil(charts[static_cast<size_t>(a)].h) > std::ceil(charts[static_cast<size_t>(b)].h);
  });
  const int P = options.page_size, pad = options.padding;
  int page = 0, x = 0, y = 0, shelf = 0;
  std::vector<Vec2> used(1, Vec2::Zero());
  for (int id : order) {
    Chart& ch = charts[static_cast<size_t>(id)];
    const int cw = static_cast<int>(std::ceil(ch.w)) + 2 * pad + 1, chh = static_cast<int>(std::ceil(ch.h)) + 2 * pad + 1;
    if (x + cw > P) {
      x = 0;
      y += shelf;
      shelf = 0;
    }
    if (y + chh > P) {
      ++page;
      used.emplace_back(0, 0);
      x = y = shelf = 0;
    }
    ch.page = page;
    ch.at = Vec2(x + pad, y + pad);
    x += cw;
    shelf = std::max(shelf, chh);
    used[static_cast<size_t>(page)] = used[static_cast<size_t>(page)].cwiseMax(Vec2(x, y + chh));
  }
  const int num_pages = page + 1;
  // 4. mesh: pages, materials, faces grouped by page then packing order
  TexturedMesh& mesh = model.mesh;
  mesh = TexturedMesh();
  for (int k = 0; k < num_pages; ++k) {
    Material m;
    m.name = "material_" + std::to_string(k);
    m.extra_lines = {"Ka 1 1 1", "Kd 1 1 1", "Ks 0 0 0", "Ns 0"};
    m.map_kd = model.name + "_" + std::to_string(k) + ".jpg";
    mesh.materials.push_back(m);
    Page pg;
    pg.material = m.name;
    pg.image_path = m.map_kd;
    // full pages stay full; the last one is trimmed to the power of two covering its charts
    pg.width = k + 1 < num_pages ? P : std::min(P, next_pow2(static_cast<int>(used[static_cast<size_t>(k)].x())));
    pg.height = k + 1 < num_pages ? P : std::min(P, next_pow2(static_cast<int>(used[static_cast<size_t>(k)].y())));
    mesh.pages.push_back(pg);
  }
  std::vector<int> page_order = order;
  std::stable_sort(page_order.begin(), page_order.end(), [&](int a, int b) {
    return charts[static_cast<size_t>(a)].page < charts[static_cast<size_t>(b)].page;
  });
  SynthTruth& truth = model.truth;
  truth.face_plane.clear();
  truth.face_class.clear();
  truth.face_view.clear();
  truth.face_chart.clear();
  int chart_no = 0;
  for (int id : page_order) {
    const Chart& ch = charts[static_cast<size_t>(id)];
    const Page& pg = mesh.pages[static_cast<size_t>(ch.page)];
    const int base = static_cast<int>(mesh.positions.size());
    for (size_t i = 0; i < ch.verts.size(); ++i) {
      mesh.positions.push_back(raw.positions[static_cast<size_t>(ch.verts[i])]);
      const Vec2 t = ch.at + ch.uv[i];
      mesh.texcoords.emplace_back(t.x() / pg.width, t.y() / pg.height);
    }
    local.clear();
    for (size_t i = 0; i < ch.verts.size(); ++i) local.emplace(ch.verts[i], static_cast<int>(i));
    for (int f : chart_faces[static_cast<size_t>(id)]) {
      Face fc;
      for (int k = 0; k < 3; ++k) {
        const int li = base + local[raw.tris[static_cast<size_t>(f)][static_cast<size_t>(k)]];
        fc.v[static_cast<size_t>(k)] = li;
        fc.vt[static_cast<size_t>(k)] = li;
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
    }
    ++chart_no;
  }
  truth.num_charts = chart_no;
  // 5. colours
  model.pages.assign(static_cast<size_t>(num_pages), Image());
  for (int k = 0; k < num_pages; ++k) {
    Image& img = model.pages[static_cast<size_t>(k)];
    img.width = mesh.pages[static_cast<size_t>(k)].width;
    img.height = mesh.pages[static_cast<size_t>(k)].height;
    img.channels = 3;
    img.pixels.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 0);
  }
  if (!options.render_pages) return;
  Palette palette(shape, rng);
  std::vector<std::vector<uint8_t>> filled(static_cast<size_t>(num_pages));
  for (int k = 0; k < num_pages; ++k)
    filled[static_cast<size_t>(k)].assign(static_cast<size_t>(model.pages[static_cast<size_t>(k)].width) *
                                          static_cast<size_t>(model.pages[static_cast<size_t>(k)].height), 0);
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
        for (int ch = 0; ch < 3; ++ch) px[ch] = to_byte(alb[ch] * cam.exposure * cam.colour_gain[ch] + grain);
        mask[static_cast<size_t>(row) * static_cast<size_t>(img.width) + static_cast<size_t>(xx)] = 1;
      }
  }
  // dilate into the padding: each pass fills empty texels next to filled ones with their mean
  for (int k = 0; k < num_pages; ++k) {
    Image& img = model.pages[static_cast<size_t>(k)];
    std::vector<uint8_t>& mask = filled[static_cast<size_t>(k)];
    for (int pass = 0; pass < pad + 1; ++pass) {
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

}  // namespace texdefrag::synth::detail
