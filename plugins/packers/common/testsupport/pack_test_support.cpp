#include "pack_test_support.h"

#include "texdefrag/io/obj.h"
#include "texdefrag/packers/geometry.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/stage/registry.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>

namespace texdefrag::packtest {

TexturedMesh polygon_mesh(const std::vector<std::vector<Vec2>>& polys, int page_size) {
  TexturedMesh m;
  Material mat;
  mat.name = "page0";
  mat.map_kd = "page0.png";
  m.materials.push_back(mat);
  Page p;
  p.material = "page0";
  p.image_path = "page0.png";
  p.width = page_size;
  p.height = page_size;
  m.pages.push_back(p);
  for (size_t c = 0; c < polys.size(); ++c) {
    const auto& poly = polys[c];
    const int v0 = static_cast<int>(m.positions.size());
    const int t0 = static_cast<int>(m.texcoords.size());
    for (const Vec2& q : poly) {
      m.positions.emplace_back(q.x(), q.y(), static_cast<double>(c));
      m.texcoords.emplace_back(q.x() / page_size, q.y() / page_size);
    }
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      Face f;
      f.v = {v0, v0 + static_cast<int>(k), v0 + static_cast<int>(k) + 1};
      f.vt = {t0, t0 + static_cast<int>(k), t0 + static_cast<int>(k) + 1};
      f.material = 0;
      f.page = 0;
      f.source_line = static_cast<int>(m.faces.size()) + 1;
      m.faces.push_back(f);
    }
  }
  return m;
}

std::vector<std::vector<Vec2>> random_polygons(std::mt19937& rng, int count, double min_side, double max_side,
                                               int page_size) {
  std::uniform_real_distribution<double> side(min_side, max_side), pos(0, page_size - max_side * 1.5),
      ang(0, 6.283185307179586);
  std::uniform_int_distribution<int> kind(0, 3);
  std::vector<std::vector<Vec2>> out;
  for (int i = 0; i < count; ++i) {
    const Vec2 o(pos(rng) + max_side * 0.75, pos(rng) + max_side * 0.75);
    const double a = side(rng), b = side(rng) * 0.5;
    std::vector<Vec2> poly;
    switch (kind(rng)) {
      case 0:  // axis-aligned rectangle
        poly = {{0, 0}, {a, 0}, {a, b}, {0, b}};
        break;
      case 1: {  // rotated rectangle
        const double t = ang(rng);
        for (const Vec2& q : {Vec2(0, 0), Vec2(a, 0), Vec2(a, b), Vec2(0, b)}) poly.push_back(packing::rotate(q, t));
        break;
      }
      case 2:  // triangle
        poly = {{0, 0}, {a, 0}, {a * 0.3, b + 0.5}};
        break;
      default: {  // convex pentagon
        const double t = ang(rng);
        for (int k = 0; k < 5; ++k) {
          const double phi = t + k * 1.2566370614359172;
          poly.emplace_back(0.5 * a * std::cos(phi), 0.5 * b * std::sin(phi));
        }
      }
    }
    for (Vec2& q : poly) q += o;
    out.push_back(poly);
  }
  return out;
}

std::vector<std::vector<Vec2>> building_polygons(std::mt19937& rng, int count, int page_size) {
  std::uniform_int_distribution<int> big(40, 300), small(3, 24), pos(0, page_size - 320);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::vector<Vec2>> out;
  for (int i = 0; i < count; ++i) {
    const Vec2 o(pos(rng), pos(rng));
    std::vector<Vec2> poly;
    if (u(rng) < 0.3) {
      const double a = big(rng), b = big(rng) * 0.6;
      poly = {{0, 0}, {a, 0}, {a, b}, {0, b}};
    } else if (u(rng) < 0.5) {
      const double a = small(rng), b = small(rng);
      poly = {{0, 0}, {a, 0}, {a, b}, {0, b}};
    } else {
      const double a = small(rng), b = small(rng);
      poly = {{0, 0}, {a, 0}, {0, b}};
    }
    for (Vec2& q : poly) q += o;
    out.push_back(poly);
  }
  return out;
}

std::unique_ptr<PackRun> run_packer(const std::string& name, TexturedMesh mesh, const json& options,
                                    const std::function<void(Atlas&)>& edit, const ProgressFn& progress) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  auto run = std::make_unique<PackRun>();
  run->mesh = std::move(mesh);
  run->topo = build_topology(run->mesh);
  run->charts = build_charts(run->mesh, run->topo);
  run->ctx.mesh = &run->mesh;
  run->ctx.topology = &run->topo;
  run->ctx.input_charts = &run->charts;
  run->ctx.atlas = run->charts.atlas;
  if (edit) edit(run->ctx.atlas);
  run->ctx.report = &run->report;
  run->ctx.progress = progress ? progress : [](const std::string&, double) { return true; };
  std::unique_ptr<Stage> st = reg.create(name);
  const StageInfo* info = reg.find(name);
  st->set_options(default_options(*info, options));
  auto* packer = dynamic_cast<Packer*>(st.get());
  if (!packer) throw std::runtime_error(name + " is not a packer");
  packer->pack(run->ctx);
  return run;
}

void expect_valid_layout(const PackRun& run, int gutter) {
  const Atlas& a = run.ctx.atlas;
  const Layout& L = run.ctx.layout;
  ASSERT_EQ(L.chart_page.size(), static_cast<size_t>(a.num_charts));
  ASSERT_EQ(L.wedge_uv.size(), a.wedge_uv.size());
  const auto faces = a.chart_faces();
  // Placement inside the page, rigid motion per chart.
  for (int c = 0; c < a.num_charts; ++c) {
    const int page = L.chart_page[static_cast<size_t>(c)];
    ASSERT_GE(page, 0) << "chart " << c;
    ASSERT_LT(static_cast<size_t>(page), L.pages.size());
    const auto& ps = L.pages[static_cast<size_t>(page)];
    for (int f : faces[static_cast<size_t>(c)]) {
      Vec2 in[3], out[3];
      for (int k = 0; k < 3; ++k) {
        const int w = a.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)];
        in[k] = a.wedge_uv[static_cast<size_t>(w)];
        out[k] = L.wedge_uv[static_cast<size_t>(w)];
        EXPECT_TRUE(out[k].x() >= 0 && out[k].y() >= 0 && out[k].x() <= ps.width && out[k].y() <= ps.height)
            << "chart " << c << " wedge " << w << " at " << out[k].transpose() << " page " << ps.width << "x"
            << ps.height;
      }
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR((in[(k + 1) % 3] - in[k]).norm(), (out[(k + 1) % 3] - out[k]).norm(), 1e-6) << "chart " << c;
      const double sa = (in[1] - in[0]).x() * (in[2] - in[0]).y() - (in[1] - in[0]).y() * (in[2] - in[0]).x();
      const double sb = (out[1] - out[0]).x() * (out[2] - out[0]).y() - (out[1] - out[0]).y() * (out[2] - out[0]).x();
      EXPECT_NEAR(sa, sb, 1e-6 * std::max(1.0, std::abs(sa))) << "chart " << c << " mirrored or scaled";
    }
  }
  // Gutter: each chart's cells (its triangles rasterised within its box [floor(min), ceil(max)))
  // dilated by [-lo, hi] must not meet another chart's dilated cells, i.e. at least `gutter` empty
  // cells between any two charts.
  const int lo = gutter / 2, hi = gutter - gutter / 2;
  std::vector<std::vector<int>> owner(L.pages.size());
  for (size_t p = 0; p < L.pages.size(); ++p)
    owner[p].assign(static_cast<size_t>(L.pages[p].width) * static_cast<size_t>(L.pages[p].height), -1);
  size_t conflicts = 0;
  for (int c = 0; c < a.num_charts; ++c) {
    const auto& fs = faces[static_cast<size_t>(c)];
    if (fs.empty()) continue;
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (int f : fs)
      for (int w : a.face_wedge[static_cast<size_t>(f)]) {
        const Vec2& q = L.wedge_uv[static_cast<size_t>(w)];
        x0 = std::min(x0, q.x()); y0 = std::min(y0, q.y());
        x1 = std::max(x1, q.x()); y1 = std::max(y1, q.y());
      }
    const int ox = static_cast<int>(std::floor(x0)), oy = static_cast<int>(std::floor(y0));
    packing::Mask m;
    m.width = std::max(1, static_cast<int>(std::ceil(x1)) - ox);
    m.height = std::max(1, static_cast<int>(std::ceil(y1)) - oy);
    m.cells.assign(static_cast<size_t>(m.width) * static_cast<size_t>(m.height), 0);
    const Vec2 o(ox, oy);
    for (int f : fs) {
      const auto& fw = a.face_wedge[static_cast<size_t>(f)];
      packing::rasterise_triangle(L.wedge_uv[static_cast<size_t>(fw[0])] - o, L.wedge_uv[static_cast<size_t>(fw[1])] - o,
                                  L.wedge_uv[static_cast<size_t>(fw[2])] - o, m);
    }
    const packing::Mask d = packing::dilate(m, lo, hi);
    const size_t page = static_cast<size_t>(L.chart_page[static_cast<size_t>(c)]);
    const int W = L.pages[page].width, H = L.pages[page].height;
    for (int y = 0; y < d.height; ++y)
      for (int x = 0; x < d.width; ++x) {
        if (!d.at(x, y)) continue;
        const int gx = ox - lo + x, gy = oy - lo + y;
        if (gx < 0 || gy < 0 || gx >= W || gy >= H) continue;
        int& cell = owner[page][static_cast<size_t>(gy) * static_cast<size_t>(W) + static_cast<size_t>(gx)];
        if (cell >= 0 && cell != c) {
          if (conflicts < 5) ADD_FAILURE() << "charts " << cell << " and " << c << " closer than gutter " << gutter
                                           << " at cell (" << gx << ", " << gy << ") of page " << page;
          ++conflicts;
        }
        cell = c;
      }
  }
  EXPECT_EQ(conflicts, 0u);
}

double layout_efficiency(const PackRun& run) {
  const Atlas& a = run.ctx.atlas;
  double uv = 0, pages = 0;
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    if (a.face_chart[f] < 0) continue;
    const auto& w = a.face_wedge[f];
    const Vec2 p0 = run.ctx.layout.wedge_uv[static_cast<size_t>(w[0])];
    const Vec2 e1 = run.ctx.layout.wedge_uv[static_cast<size_t>(w[1])] - p0;
    const Vec2 e2 = run.ctx.layout.wedge_uv[static_cast<size_t>(w[2])] - p0;
    uv += 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  }
  for (const auto& p : run.ctx.layout.pages) pages += static_cast<double>(p.width) * p.height;
  return pages > 0 ? uv / pages : 0.0;
}

double exact_chart_fraction(const PackRun& run) {
  const Atlas& a = run.ctx.atlas;
  const Layout& L = run.ctx.layout;
  const auto faces = a.chart_faces();
  size_t exact = 0, total = 0;
  for (int c = 0; c < a.num_charts; ++c) {
    const auto& fs = faces[static_cast<size_t>(c)];
    if (fs.empty()) continue;
    ++total;
    const int w0 = a.face_wedge[static_cast<size_t>(fs[0])][0];
    bool any = false;
    for (int k = 0; k < 4 && !any; ++k) {
      const Vec2 t = L.wedge_uv[static_cast<size_t>(w0)] - packing::rotate90(a.wedge_uv[static_cast<size_t>(w0)], k);
      if (std::abs(t.x() - std::round(t.x())) > 1e-9 || std::abs(t.y() - std::round(t.y())) > 1e-9) continue;
      bool ok = true;
      for (int f : fs)
        for (int w : a.face_wedge[static_cast<size_t>(f)])
          if ((L.wedge_uv[static_cast<size_t>(w)] - packing::rotate90(a.wedge_uv[static_cast<size_t>(w)], k) - t)
                  .cwiseAbs()
                  .maxCoeff() > 1e-9)
            ok = false;
      any = ok;
    }
    exact += any ? 1 : 0;
  }
  return total ? static_cast<double>(exact) / static_cast<double>(total) : 1.0;
}

void packer_invariant_suite(const std::string& name) {
  SCOPED_TRACE(name);
  std::mt19937 rng(11);
  // 1. Random charts, several gutters: valid, and (the atlas is the input) every chart exact.
  for (int gutter : {0, 2, 4, 7}) {
    SCOPED_TRACE("gutter " + std::to_string(gutter));
    auto run = run_packer(name, polygon_mesh(random_polygons(rng, 300, 2, 60, 2048), 2048), {{"gutter", gutter}});
    expect_valid_layout(*run, gutter);
    EXPECT_EQ(exact_chart_fraction(*run), 1.0);
    ASSERT_EQ(run->ctx.layout.pages.size(), 1u);
    const double eff = layout_efficiency(*run);
    EXPECT_NEAR(run->report.at("packing_efficiency").get<double>(), eff, 1e-6);
    EXPECT_GT(eff, 0.2);
    EXPECT_LE(eff, 1.0);
    EXPECT_EQ(run->report.at("pages").get<int>(), 1);
    EXPECT_EQ(run->report.at("charts").get<size_t>(), 300u);
    EXPECT_EQ(run->report.at("charts_exact").get<size_t>(), 300u);
    for (const auto& p : run->ctx.layout.pages) {
      EXPECT_EQ(p.width % 32, 0);
      EXPECT_EQ(p.height % 32, 0);
    }
  }
  // 2. Multiple pages when max_page_size is small; every page within the limit.
  {
    std::vector<std::vector<Vec2>> squares;
    for (int i = 0; i < 40; ++i) {
      const double x = 10.0 * i, s = 90;
      squares.push_back({{x, 0}, {x + s, 0}, {x + s, s}, {x, s}});
    }
    auto run = run_packer(name, polygon_mesh(squares, 1024), {{"max_page_size", 256}, {"gutter", 4}});
    expect_valid_layout(*run, 4);
    EXPECT_GE(run->ctx.layout.pages.size(), 6u);  // 40 squares of 95^2 padded, at most 4 per 256^2 page
    for (const auto& p : run->ctx.layout.pages) {
      EXPECT_LE(p.width, 256);
      EXPECT_LE(p.height, 256);
    }
    EXPECT_EQ(run->report.at("pages").get<size_t>(), run->ctx.layout.pages.size());
  }
  // 3. Power-of-two pages.
  {
    auto run = run_packer(name, polygon_mesh(random_polygons(rng, 50, 2, 40, 1024), 1024),
                          {{"power_of_two", true}});
    expect_valid_layout(*run, 4);
    for (const auto& p : run->ctx.layout.pages) {
      EXPECT_EQ(p.width & (p.width - 1), 0) << p.width;
      EXPECT_EQ(p.height & (p.height - 1), 0) << p.height;
    }
  }
  // 4. A chart larger than a page is an error naming the chart.
  {
    const std::vector<std::vector<Vec2>> polys = {{{0, 0}, {10, 0}, {10, 10}, {0, 10}},
                                                  {{0, 0}, {500, 0}, {500, 300}, {0, 300}}};
    try {
      run_packer(name, polygon_mesh(polys, 1024), {{"max_page_size", 256}});
      ADD_FAILURE() << "expected StageError";
    } catch (const StageError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(name + ": chart 1"), std::string::npos) << msg;
      EXPECT_NE(msg.find("max_page_size 256"), std::string::npos) << msg;
    }
  }
  // 5. A merged chart (atlas rotated away from the input by 0.4 rad, so it is resampled anyway):
  //    rigid and in page whether or not the packer rotates it freely.
  {
    const std::vector<std::vector<Vec2>> polys = {{{100, 100}, {300, 100}, {300, 140}, {100, 140}},
                                                  {{400, 400}, {420, 400}, {420, 420}, {400, 420}}};
    auto run = run_packer(name, polygon_mesh(polys, 1024), json::object(), [](Atlas& a) {
      std::vector<uint8_t> done(a.wedge_uv.size(), 0);
      for (size_t f = 0; f < a.face_chart.size(); ++f)
        if (a.face_chart[f] == 0)
          for (int w : a.face_wedge[f])
            if (!done[static_cast<size_t>(w)]) {
              done[static_cast<size_t>(w)] = 1;
              a.wedge_uv[static_cast<size_t>(w)] = packing::rotate(a.wedge_uv[static_cast<size_t>(w)], 0.4) + Vec2(500, 0);
            }
    });
    expect_valid_layout(*run, 4);
    EXPECT_EQ(run->report.at("charts_exact").get<int>(), 1);
  }
}

std::vector<std::pair<std::string, double>> packer_real_suite(const std::string& name, size_t max_faces) {
  std::vector<std::pair<std::string, double>> out;
  for (const std::string& path : ::texdefrag::testing::real_models(max_faces)) {
    SCOPED_TRACE(path);
    TexturedMesh mesh = read_obj(path);
    auto run = run_packer(name, std::move(mesh));
    expect_valid_layout(*run, 4);
    EXPECT_EQ(exact_chart_fraction(*run), 1.0);
    const double eff = layout_efficiency(*run);
    EXPECT_NEAR(run->report.at("packing_efficiency").get<double>(), eff, 1e-6);
    EXPECT_GT(eff, 0.1);
    EXPECT_LE(eff, 1.0);
    out.emplace_back(std::filesystem::path(path).filename().string(), eff);
  }
  return out;
}

}  // namespace texdefrag::packtest
