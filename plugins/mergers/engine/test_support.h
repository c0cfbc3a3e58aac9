// Test helpers shared by the mergers' tests: small meshes with known answers and a stage runner.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/distortion.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"

#include <array>
#include <cmath>
#include <memory>
#include <string>

namespace texdefrag::merge::test {

/// A mesh with no faces yet and one `side` x `side`-texel page (material "m", image never read):
/// where the hand-built meshes of these tests start.
inline TexturedMesh one_page_mesh(int side) {
  TexturedMesh m;
  Page pg;
  pg.material = "m";
  pg.width = pg.height = side;
  pg.image_path = "unused.png";
  m.pages.push_back(pg);
  return m;
}

/// Adds face (a, b, c) on page 0 with texels ta, tb, tc, one texcoord per corner (so every face has
/// its own wedges until the charts are built, which weld equal texcoords of a vertex); texcoords are
/// the texels over the page's width (one_page_mesh: square pages).
inline void add_texel_face(TexturedMesh& m, std::array<int, 3> v, std::array<Vec2, 3> t) {
  Face f;
  f.page = 0;
  f.source_line = static_cast<int>(m.faces.size()) + 1;
  const double side = m.pages[0].width;
  for (size_t k = 0; k < 3; ++k) {
    f.v[k] = v[k];
    f.vt[k] = static_cast<int>(m.texcoords.size());
    m.texcoords.push_back(t[k] / side);
  }
  m.faces.push_back(f);
}

/// fragmented_grid_mesh with each triangle's UVs scaled about its first corner by 1 + amp * (+-1)
/// alternately (amp = 0: the fixture unchanged): merging then has to distort.
inline TexturedMesh distorted_fragmented_grid(int nx, int ny, double amp) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(nx, ny, 1024, "unused.png");
  for (size_t f = 0; f < m.faces.size(); ++f) {
    const double s = 1 + amp * (f % 2 ? 1 : -1);
    const Vec2 o = m.texcoords[static_cast<size_t>(m.faces[f].vt[0])];
    for (int k = 1; k < 3; ++k) {
      Vec2& t = m.texcoords[static_cast<size_t>(m.faces[f].vt[static_cast<size_t>(k)])];
      t = o + s * (t - o);
    }
  }
  return m;
}

/// fragmented_grid_mesh folded 90 degrees along x = nx/2 (two perpendicular planes); region 0 for
/// faces with x < nx/2, region 1 for the others.
inline TexturedMesh folded_grid(int nx, int ny, std::vector<int>& region) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(nx, ny, 1024, "unused.png");
  const double h = nx / 2;
  region.assign(m.faces.size(), 0);
  for (size_t f = 0; f < m.faces.size(); ++f) {
    double cx = 0;
    for (int k = 0; k < 3; ++k) cx += m.corner_position(f, k).x() / 3;
    region[f] = cx < h ? 0 : 1;
  }
  for (Vec3& p : m.positions)
    if (p.x() > h) p = Vec3(h, p.y(), p.x() - h);
  return m;
}

/// Everything a merger needs, built from a mesh.
struct Run {
  TexturedMesh mesh;
  Topology topo;
  ChartSet charts;
  StageContext ctx;
  json report = json::object();

  explicit Run(TexturedMesh m, std::vector<int> regions = {}) : mesh(std::move(m)) {
    topo = build_topology(mesh);
    charts = build_charts(mesh, topo);
    ctx.mesh = &mesh;
    ctx.topology = &topo;
    ctx.input_charts = &charts;
    ctx.atlas = charts.atlas;
    if (regions.empty()) {
      // The M-method's behaviour: one region for every textured face.
      regions.assign(mesh.faces.size(), 0);
      for (size_t f = 0; f < mesh.faces.size(); ++f)
        if (mesh.faces[f].page == kNoPage) regions[f] = -1;
    }
    int n = 0;
    for (int r : regions) n = std::max(n, r + 1);
    ctx.regions.face_region = std::move(regions);
    ctx.regions.num_regions = n;
    ctx.report = &report;
    ctx.progress = [](const std::string&, double) { return true; };
  }

  /// Replaces the regions with those of detector stage `name` (created by name, default options).
  /// Returns false when that detector module is not built.
  bool detect(const std::string& name) {
    Registry& r = Registry::instance();
    r.load_plugins();
    const StageInfo* info = r.find(name);
    if (!info) return false;
    std::unique_ptr<Stage> s = r.create(name);
    s->set_options(default_options(*info, json::object()));
    auto* d = dynamic_cast<Detector*>(s.get());
    if (!d) return false;
    json rep = json::object();
    ctx.report = &rep;
    d->detect(ctx);
    ctx.report = &report;
    return true;
  }

  /// Creates stage `name` by name with option overrides and runs it on ctx.
  void merge(const std::string& name, const json& overrides = json::object()) {
    Registry& r = Registry::instance();
    r.load_plugins();
    const StageInfo* info = r.find(name);
    ASSERT_NE(info, nullptr) << name;
    std::unique_ptr<Stage> s = r.create(name);
    s->set_options(default_options(*info, overrides));
    auto* m = dynamic_cast<Merger*>(s.get());
    ASSERT_NE(m, nullptr);
    const int charts_in = ctx.atlas.num_charts;
    m->merge(ctx);
    // As the pipeline adds the framework's figures and checks the merger's distortion contract.
    const DistortionSummary d = report_merger_figures(mesh, charts_in, ctx.atlas, report);
    check_merger_distortion(name, d, m->distortion_budget());
  }
};

/// Invariants every merger result must satisfy: every textured face has a chart and wedges, no
/// face is flipped, charts are UV-connected components of shared wedges.
inline void expect_valid_atlas(const Run& run) {
  const Atlas& at = run.ctx.atlas;
  ASSERT_EQ(at.face_chart.size(), run.mesh.faces.size());
  for (size_t f = 0; f < run.mesh.faces.size(); ++f) {
    if (run.mesh.faces[f].page == kNoPage) continue;
    ASSERT_GE(at.face_chart[f], 0) << "face " << f << " lost its chart";
    ASSERT_LT(at.face_chart[f], at.num_charts);
    for (int w : at.face_wedge[f]) {
      ASSERT_GE(w, 0);
      ASSERT_LT(static_cast<size_t>(w), at.wedge_uv.size());
    }
  }
  const DistortionSummary d = atlas_distortion(run.mesh, at);
  EXPECT_EQ(d.flipped, 0u);
}

/// The same atlas bit for bit: charts, wedges per face and every wedge's UV (`what` names the run).
inline void expect_same_atlas(const Atlas& got, const Atlas& want, const std::string& what) {
  EXPECT_EQ(got.face_chart, want.face_chart) << what;
  EXPECT_EQ(got.face_wedge, want.face_wedge) << what;
  ASSERT_EQ(got.wedge_uv.size(), want.wedge_uv.size()) << what;
  for (size_t w = 0; w < want.wedge_uv.size(); ++w)
    ASSERT_TRUE(got.wedge_uv[w] == want.wedge_uv[w]) << "wedge " << w << ", " << what;
}

}  // namespace texdefrag::merge::test
