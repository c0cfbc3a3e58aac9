#include "common/test_meshes.h"

#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

namespace texdefrag::detectors::testmesh {

void Builder::add(const Vec3& a, const Vec3& b, const Vec3& c, int chart, int truth) {
  tris_.push_back({a, b, c});
  chart_.push_back(chart);
  truth_.push_back(truth);
}

int Builder::add_grid(const Vec3& origin, const Vec3& U, const Vec3& V, int nu, int nv, int pu, int pv,
                      int chart_base, int truth) {
  // note: (U * i) / nu, not U * (i / nu): exact for integer coordinates, so grids sharing an edge
  // produce bit-identical points there (topology welds by exact equality).
  auto P = [&](int i, int j) {
    return Vec3(origin + (U * static_cast<double>(i)) / static_cast<double>(nu) + (V * static_cast<double>(j)) / static_cast<double>(nv));
  };
  const int cu = (nu + pu - 1) / pu;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int chart = chart_base + (j / pv) * cu + i / pu;
      add(P(i, j), P(i + 1, j), P(i + 1, j + 1), chart, truth);
      add(P(i, j), P(i + 1, j + 1), P(i, j + 1), chart, truth);
    }
  return chart_base + cu * ((nv + pv - 1) / pv);
}

Case Builder::build(const std::string& name) const {
  Case c;
  c.name = name;
  TexturedMesh& m = c.mesh;
  Material mat;
  mat.name = "page0";
  mat.map_kd = "page0.png";
  m.materials.push_back(mat);
  Page page;
  page.material = "page0";
  page.image_path = "page0.png";
  page.width = page.height = 1024;
  m.pages.push_back(page);
  // Charts renumbered densely in order of first triangle.
  std::map<int, int> dense;
  for (int ch : chart_) dense.emplace(ch, static_cast<int>(dense.size()));
  const int nc = static_cast<int>(dense.size());
  const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(nc)))));
  const double cell = 1.0 / cols;
  // Per chart: a projection basis from the summed triangle normals and the bounding box of the
  // projected points, to fit the island into 80% of its cell.
  std::vector<Vec3> nsum(static_cast<size_t>(nc), Vec3::Zero());
  std::vector<std::array<Vec3, 3>> pts(tris_.size());
  for (size_t t = 0; t < tris_.size(); ++t) {
    for (int k = 0; k < 3; ++k) pts[t][static_cast<size_t>(k)] = tris_[t][static_cast<size_t>(k)] + (noise_ ? noise_(tris_[t][static_cast<size_t>(k)]) : Vec3::Zero());
    nsum[static_cast<size_t>(dense[chart_[t]])] += (pts[t][1] - pts[t][0]).cross(pts[t][2] - pts[t][0]);
  }
  std::vector<Vec3> e1(static_cast<size_t>(nc)), e2(static_cast<size_t>(nc));
  std::vector<Vec2> lo(static_cast<size_t>(nc), Vec2::Constant(1e300)), hi(static_cast<size_t>(nc), Vec2::Constant(-1e300));
  for (int ch = 0; ch < nc; ++ch) {
    Vec3 n = nsum[static_cast<size_t>(ch)].norm() > 0 ? nsum[static_cast<size_t>(ch)].normalized() : Vec3::UnitZ();
    Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    e1[static_cast<size_t>(ch)] = (a - n * n.dot(a)).normalized();
    e2[static_cast<size_t>(ch)] = n.cross(e1[static_cast<size_t>(ch)]);
  }
  auto proj = [&](int ch, const Vec3& p) { return Vec2(p.dot(e1[static_cast<size_t>(ch)]), p.dot(e2[static_cast<size_t>(ch)])); };
  for (size_t t = 0; t < tris_.size(); ++t) {
    const int ch = dense[chart_[t]];
    for (const Vec3& p : pts[t]) {
      lo[static_cast<size_t>(ch)] = lo[static_cast<size_t>(ch)].cwiseMin(proj(ch, p));
      hi[static_cast<size_t>(ch)] = hi[static_cast<size_t>(ch)].cwiseMax(proj(ch, p));
    }
  }
  // Positions and texcoords duplicated per chart, shared within a chart (keyed by exact position).
  std::map<std::pair<int, std::array<double, 3>>, int> index;
  for (size_t t = 0; t < tris_.size(); ++t) {
    const int ch = dense[chart_[t]];
    Face f;
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = pts[t][static_cast<size_t>(k)];
      const auto key = std::make_pair(ch, std::array<double, 3>{p.x(), p.y(), p.z()});
      auto it = index.find(key);
      if (it == index.end()) {
        const Vec2 ext = (hi[static_cast<size_t>(ch)] - lo[static_cast<size_t>(ch)]).cwiseMax(1e-12);
        const double s = 0.8 * cell / std::max(ext.x(), ext.y());
        const Vec2 q = (proj(ch, p) - lo[static_cast<size_t>(ch)]) * s;
        const Vec2 uv((ch % cols) * cell + 0.1 * cell + q.x(), (ch / cols) * cell + 0.1 * cell + q.y());
        it = index.emplace(key, static_cast<int>(m.positions.size())).first;
        m.positions.push_back(p);
        m.texcoords.push_back(uv);
      }
      f.v[static_cast<size_t>(k)] = it->second;
      f.vt[static_cast<size_t>(k)] = it->second;
    }
    f.material = 0;
    f.page = 0;
    f.source_line = static_cast<int>(t) + 1;
    m.faces.push_back(f);
  }
  c.truth = truth_;
  return c;
}

std::function<Vec3(const Vec3&)> hash_noise(double amplitude, unsigned seed) {
  return [amplitude, seed](const Vec3& p) {
    Vec3 d;
    for (int k = 0; k < 3; ++k) {
      uint64_t h = 1469598103934665603ULL ^ (seed * 0x9E3779B97F4A7C15ULL) ^ static_cast<uint64_t>(k);
      for (int c = 0; c < 3; ++c) {
        double x = p[c] == 0.0 ? 0.0 : p[c];
        uint64_t b;
        std::memcpy(&b, &x, sizeof b);
        h = (h ^ b) * 1099511628211ULL;
        h ^= h >> 29;
      }
      h *= 0xBF58476D1CE4E5B9ULL;
      h ^= h >> 31;
      d[k] = amplitude * (2.0 * static_cast<double>(h >> 11) / 9007199254740992.0 - 1.0);
    }
    return d;
  };
}

Case jagged_case() {
  Builder b(hash_noise(0.22, 7));
  // Wall: plane y = 0, x in [0, 16], z in [0, 10]; roof: plane z = 10, y in [0, 10].
  int next = b.add_grid(Vec3(0, 0, 0), Vec3(16, 0, 0), Vec3(0, 0, 10), 16, 10, 2, 2, 0, 0);
  b.add_grid(Vec3(0, 0, 10), Vec3(16, 0, 0), Vec3(0, 10, 0), 16, 10, 2, 2, next, 1);
  return b.build("jagged");
}

Case strip_case() {
  Builder b;
  // Facade y = 0, x in [0, 16], z in [0, 10]; rows 4-5 and 5-6 of x in [2, 14] form a ledge whose
  // middle line (z = 5) sticks out to y = -0.7 (rows tilted by 35 degrees).
  int next = 0;
  next = b.add_grid(Vec3(0, 0, 0), Vec3(16, 0, 0), Vec3(0, 0, 4), 16, 4, 2, 2, next, 0);
  next = b.add_grid(Vec3(0, 0, 6), Vec3(16, 0, 0), Vec3(0, 0, 4), 16, 4, 2, 2, next, 0);
  next = b.add_grid(Vec3(0, 0, 4), Vec3(2, 0, 0), Vec3(0, 0, 2), 2, 2, 2, 2, next, 0);
  next = b.add_grid(Vec3(14, 0, 4), Vec3(2, 0, 0), Vec3(0, 0, 2), 2, 2, 2, 2, next, 0);
  const double out = -0.7;
  for (int i = 2; i < 14; ++i) {
    const double x0 = i, x1 = i + 1;
    // note: the ledge's side triangles close the gap at its two ends (x = 2 and x = 14).
    const int lower = next + (i - 2) / 4, upper = next + 3 + (i - 2) / 4;
    b.add(Vec3(x0, 0, 4), Vec3(x1, 0, 4), Vec3(x1, out, 5), lower, 0);
    b.add(Vec3(x0, 0, 4), Vec3(x1, out, 5), Vec3(x0, out, 5), lower, 0);
    b.add(Vec3(x0, out, 5), Vec3(x1, out, 5), Vec3(x1, 0, 6), upper, 0);
    b.add(Vec3(x0, out, 5), Vec3(x1, 0, 6), Vec3(x0, 0, 6), upper, 0);
  }
  next += 6;
  b.add(Vec3(2, 0, 4), Vec3(2, out, 5), Vec3(2, 0, 6), next, 0);
  b.add(Vec3(14, 0, 4), Vec3(14, 0, 6), Vec3(14, out, 5), next + 1, 0);
  return b.build("strip");
}

Case curved_case() {
  Builder b;
  const double R = 6, H = 6;
  int next = 0;
  // Facade A: y = 0, x in [-10, 0]; corner: axis (0, R), from (0, 0) to (R, R); facade B: x = R.
  next = b.add_grid(Vec3(-10, 0, 0), Vec3(10, 0, 0), Vec3(0, 0, H), 10, 6, 2, 2, next, 0);
  next = b.add_grid(Vec3(R, R, 0), Vec3(0, 10, 0), Vec3(0, 0, H), 10, 6, 2, 2, next, 1);
  const int seg = 12;
  auto arc = [&](int s, double z) {
    if (s == 0) return Vec3(0, 0, z);
    if (s == seg) return Vec3(R, R, z);
    const double phi = M_PI / 2 * s / seg;
    return Vec3(R * std::sin(phi), R - R * std::cos(phi), z);
  };
  for (int s = 0; s < seg; ++s)
    for (int k = 0; k < 6; ++k) {
      const int chart = next + s * 3 + k / 2;
      b.add(arc(s, k), arc(s + 1, k), arc(s + 1, k + 1), chart, 2);
      b.add(arc(s, k), arc(s + 1, k + 1), arc(s, k + 1), chart, 2);
    }
  next += seg * 3;
  // A free-standing half-cylinder column (radius 1, 24 segments of 7.5 degrees), not touching the rest.
  const int cseg = 24;
  auto col = [&](int s, double z) {
    const double phi = M_PI * s / cseg;
    return Vec3(-6 + std::cos(phi), -8 - std::sin(phi), z);
  };
  for (int s = 0; s < cseg; ++s)
    for (int k = 0; k < 6; ++k) {
      const int chart = next + s * 3 + k / 2;
      b.add(col(s, k), col(s + 1, k), col(s + 1, k + 1), chart, 4);
      b.add(col(s, k), col(s + 1, k + 1), col(s, k + 1), chart, 4);
    }
  next += cseg * 3;
  // Ground, below the building, not sharing edges with it.
  b.add_grid(Vec3(-20.5, -20.5, -0.5), Vec3(40, 0, 0), Vec3(0, 40, 0), 10, 10, 2, 2, next, 3);
  return b.build("curved");
}

Case corner_chart_case() {
  Builder b(hash_noise(0.03, 3));
  // Wall y = 0 (z in [0, 8]) and roof z = 8 (y in [0, 8]), x in [0, 12]. The top wall row and the
  // first roof row share charts (2 quads along x, 1 quad on each side): charts wrap the crease.
  int next = b.add_grid(Vec3(0, 0, 0), Vec3(12, 0, 0), Vec3(0, 0, 7), 12, 7, 2, 2, 0, 0);
  next = b.add_grid(Vec3(0, 1, 8), Vec3(12, 0, 0), Vec3(0, 7, 0), 12, 7, 2, 2, next, 1);
  int wrap = next;
  b.add_grid(Vec3(0, 0, 7), Vec3(12, 0, 0), Vec3(0, 0, 1), 12, 1, 3, 1, wrap, 0);
  b.add_grid(Vec3(0, 0, 8), Vec3(12, 0, 0), Vec3(0, 1, 0), 12, 1, 3, 1, wrap, 1);
  return b.build("corner_chart");
}

Case building_case(int faces) {
  // Sides: 4 facades (W x H), roof and ground; quads of size q so that the total is about `faces`.
  const double W = 40, H = 20;
  const double quads = faces / 2.0;
  const double area = 4 * W * H + W * W + 4 * W * W;  // facades, roof, ground (2W x 2W)
  const double q = std::sqrt(area / quads);
  const int nw = std::max(2, static_cast<int>(std::lround(W / q))), nh = std::max(2, static_cast<int>(std::lround(H / q)));
  Builder b(hash_noise(0.1 * W / nw, 11));
  int next = 0;
  next = b.add_grid(Vec3(0, 0, 0), Vec3(W, 0, 0), Vec3(0, 0, H), nw, nh, 2, 2, next, 0);
  next = b.add_grid(Vec3(W, 0, 0), Vec3(0, W, 0), Vec3(0, 0, H), nw, nh, 2, 2, next, 1);
  next = b.add_grid(Vec3(W, W, 0), Vec3(-W, 0, 0), Vec3(0, 0, H), nw, nh, 2, 2, next, 2);
  next = b.add_grid(Vec3(0, W, 0), Vec3(0, -W, 0), Vec3(0, 0, H), nw, nh, 2, 2, next, 3);
  next = b.add_grid(Vec3(0, 0, H), Vec3(W, 0, 0), Vec3(0, W, 0), nw, nw, 2, 2, next, 4);
  b.add_grid(Vec3(-W / 2 - 0.25, -W / 2 - 0.25, -0.25), Vec3(2 * W, 0, 0), Vec3(0, 2 * W, 0), 2 * nw, 2 * nw, 2, 2, next, 5);
  return b.build("building");
}

Detection run_detector(const std::string& name, const TexturedMesh& mesh, const json& overrides, ProgressFn progress,
                       OutputSet* outputs) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  std::unique_ptr<Stage> stage = reg.create(name);
  auto* det = dynamic_cast<Detector*>(stage.get());
  if (!det) throw std::runtime_error(name + " is not a detector");
  det->set_options(default_options(*reg.find(name), overrides));
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  Detection d;
  StageContext ctx;
  ctx.mesh = &mesh;
  ctx.topology = &topo;
  ctx.input_charts = &charts;
  ctx.atlas = charts.atlas;
  ctx.report = &d.report;
  ctx.progress = std::move(progress);
  ctx.outputs = outputs;
  det->detect(ctx);
  d.regions = ctx.regions;
  return d;
}

}  // namespace texdefrag::detectors::testmesh
