// Tests of the hard features of the synthetic generator (issue 18, docs/synth.md "The hard
// preset"): each feature measured on the generated mesh against its requested fraction, and the
// hard preset's realism figures (charts per face, vertex replication, the M-method
// configuration's chart reduction) on a small instance against the real tiles' range.
#include "texdefrag/synth/synth.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numeric>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::synth;

namespace {

SynthOptions base(uint64_t seed, size_t faces = 6000) {
  SynthOptions o;
  o.archetype = Archetype::Residential;
  o.target_faces = faces;
  o.seed = seed;
  o.render_pages = false;
  return o;
}

/// Signed UV area (texels^2) of face f.
double signed_uv_area(const TexturedMesh& m, size_t f) {
  const Vec2 a = m.corner_texel(f, 0), b = m.corner_texel(f, 1), c = m.corner_texel(f, 2);
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

/// Texel density (UV area / 3D area) of face f.
double density(const TexturedMesh& m, size_t f) {
  const Vec3 a = m.corner_position(f, 0), b = m.corner_position(f, 1), c = m.corner_position(f, 2);
  const double a3 = 0.5 * (b - a).cross(c - a).norm();
  return a3 > 0 ? std::abs(signed_uv_area(m, f)) / a3 : 0;
}

/// Median over charts of at least 20 faces of (max / min face density) inside the chart.
double median_density_ratio(const SynthModel& m) {
  std::vector<std::vector<double>> per(static_cast<size_t>(m.truth.num_charts));
  for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
    const double d = density(m.mesh, f);
    if (d > 0) per[static_cast<size_t>(m.truth.face_chart[f])].push_back(d);
  }
  std::vector<double> ratios;
  for (auto& v : per) {
    if (v.size() < 20) continue;
    std::sort(v.begin(), v.end());
    ratios.push_back(v[v.size() * 9 / 10] / v[v.size() / 10]);  // 10th-90th percentile: robust to noise
  }
  std::sort(ratios.begin(), ratios.end());
  return ratios.empty() ? 0 : ratios[ratios.size() / 2];
}

}  // namespace

TEST(SynthHard, MirroredFractionMeasuredEqualsRequested) {
  for (double want : {0.0, 0.2, 0.46}) {
    SynthOptions o = base(3);
    o.mirror_fraction = want;
    const SynthModel m = generate(o);
    // orientation of the unmirrored faces is positive (projection with y up keeps the winding)
    size_t reversed = 0, truth = 0, faces = 0, disagree = 0;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      const double s = signed_uv_area(m.mesh, f);
      if (s == 0) continue;
      ++faces;
      reversed += s < 0 ? 1 : 0;
      truth += m.truth.face_mirrored[f];
      disagree += (s < 0) != (m.truth.face_mirrored[f] == 1) ? 1 : 0;
      // 3D winding is unchanged: the face's normal still points out of its (flat) plane
      const PlaneInfo& pl = m.truth.planes[static_cast<size_t>(m.truth.face_plane[f])];
      if (!pl.curved) {
        const Vec3 a = m.mesh.corner_position(f, 0), b = m.mesh.corner_position(f, 1), c = m.mesh.corner_position(f, 2);
        const Vec3 n = (b - a).cross(c - a);
        if (n.norm() > 1e-3) {
          EXPECT_GT(n.normalized().dot(pl.normal), 0.0) << "face " << f;
        }
      }
    }
    const double measured = static_cast<double>(reversed) / static_cast<double>(faces);
    std::printf("mirror_fraction %.2f: measured %.4f (%zu of %zu faces)\n", want, measured, reversed, faces);
    // whole charts are mirrored: the share misses the target by at most half the largest chart
    EXPECT_NEAR(measured, want, 0.03);
    // the ground truth says the same (it marks the faces of the charts it mirrored)
    EXPECT_NEAR(static_cast<double>(truth) / static_cast<double>(faces), want, 0.03);
    // a face whose projection folds (seen nearly edge-on, or from behind by its fallback camera)
    // is reversed without being mirrored, or the other way round: about 1% of the faces
    EXPECT_LE(disagree, faces / 50) << disagree << " faces";
  }
}

TEST(SynthHard, ZeroUvFacesMatchRequestedFraction) {
  SynthOptions o = base(4);
  o.zero_uv_fraction = 0.05;
  const SynthModel m = generate(o);
  size_t zero = 0;
  for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
    const bool z = signed_uv_area(m.mesh, f) == 0;
    zero += z ? 1 : 0;
    EXPECT_EQ(z, m.truth.face_zero_uv[f] == 1) << "face " << f;
  }
  const double share = static_cast<double>(zero) / static_cast<double>(m.mesh.faces.size());
  std::printf("zero_uv_fraction 0.05: measured %.4f\n", share);
  EXPECT_NEAR(share, 0.05, 0.012);  // binomial, n ~ 6000: sd 0.0028
  EXPECT_EQ(build_topology(m.mesh).report.zero_area_faces, 0u);  // 3D areas stay non-zero
}

TEST(SynthHard, OverlappingChartsLieInsideTheirHosts) {
  SynthOptions o = base(5);
  o.overlap_fraction = 0.05;
  const SynthModel m = generate(o);
  const int want = static_cast<int>(std::lround(0.05 * m.truth.num_charts));
  EXPECT_GE(static_cast<int>(m.truth.overlapping_charts.size()), want * 8 / 10);
  EXPECT_LE(static_cast<int>(m.truth.overlapping_charts.size()), want);
  std::vector<Vec2> lo(static_cast<size_t>(m.truth.num_charts), Vec2(1e300, 1e300)), hi(lo.size(), Vec2(-1e300, -1e300));
  std::vector<int> page(lo.size(), -1);
  for (size_t f = 0; f < m.mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const size_t c = static_cast<size_t>(m.truth.face_chart[f]);
      lo[c] = lo[c].cwiseMin(m.mesh.corner_texel(f, k));
      hi[c] = hi[c].cwiseMax(m.mesh.corner_texel(f, k));
      page[c] = m.mesh.faces[f].page;
    }
  for (const auto& [g, h] : m.truth.overlapping_charts) {
    EXPECT_EQ(page[static_cast<size_t>(g)], page[static_cast<size_t>(h)]);
    EXPECT_GE(lo[static_cast<size_t>(g)].x(), lo[static_cast<size_t>(h)].x() - 1.001);
    EXPECT_LE(hi[static_cast<size_t>(g)].x(), hi[static_cast<size_t>(h)].x() + 1.001);
    EXPECT_GE(lo[static_cast<size_t>(g)].y(), lo[static_cast<size_t>(h)].y() - 1.001);
    EXPECT_LE(hi[static_cast<size_t>(g)].y(), hi[static_cast<size_t>(h)].y() + 1.001);
  }
  // the eval sees them: more overlapping UV pairs than without the feature
  SynthOptions none = o;
  none.overlap_fraction = 0;
  const size_t with = eval::model_metrics(m.mesh).uv_overlaps, without = eval::model_metrics(generate(none).mesh).uv_overlaps;
  std::printf("uv overlaps: %zu with overlap_fraction 0.05, %zu without\n", with, without);
  EXPECT_GT(with, without + m.truth.overlapping_charts.size() / 2);
}

TEST(SynthHard, PerspectiveAndDensityJitterSpreadTexelDensity) {
  const SynthOptions plain = base(6);
  SynthOptions persp = plain;
  persp.perspective = 1.0;  // density ratio 3 across each chart
  const double r0 = median_density_ratio(generate(plain)), r1 = median_density_ratio(generate(persp));
  std::printf("median in-chart density ratio (p10-p90): %.3f plain, %.3f with perspective 1\n", r0, r1);
  EXPECT_GT(r1, r0 * 1.3);
  // between charts: spread of the log of the per-chart median density
  auto spread = [](const SynthModel& m) {
    std::vector<std::vector<double>> per(static_cast<size_t>(m.truth.num_charts));
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) per[static_cast<size_t>(m.truth.face_chart[f])].push_back(density(m.mesh, f));
    std::vector<double> logs;
    for (auto& v : per) {
      if (v.size() < 5) continue;
      std::sort(v.begin(), v.end());
      logs.push_back(std::log(v[v.size() / 2]));
    }
    const double mean = std::accumulate(logs.begin(), logs.end(), 0.0) / static_cast<double>(logs.size());
    double ss = 0;
    for (double l : logs) ss += (l - mean) * (l - mean);
    return std::sqrt(ss / static_cast<double>(logs.size()));
  };
  SynthOptions jit = plain;
  jit.density_jitter = 0.4;
  const double s0 = spread(generate(plain)), s1 = spread(generate(jit));
  std::printf("sd of log chart density: %.3f plain, %.3f with density_jitter 0.4\n", s0, s1);
  EXPECT_GT(s1 * s1 - s0 * s0, 0.5 * 0.4 * 0.4);  // variances add: about 0.16 more
}

TEST(SynthHard, ExposureClutterAndCrossPlaneFractions) {
  SynthOptions o = base(7, 8000);
  o.exposure_sd = 0.1;
  o.clutter_fraction = 0.25;
  o.cross_plane = 0.6;
  const SynthModel m = generate(o);
  const auto& e = m.truth.chart_exposure;
  ASSERT_EQ(static_cast<int>(e.size()), m.truth.num_charts);
  const double mean = std::accumulate(e.begin(), e.end(), 0.0) / static_cast<double>(e.size());
  double ss = 0;
  for (double v : e) ss += (v - mean) * (v - mean);
  const double sd = std::sqrt(ss / static_cast<double>(e.size()));
  const double clutter = static_cast<double>(m.truth.clutter_faces) / static_cast<double>(m.mesh.faces.size());
  SynthOptions o0 = base(7, 8000);
  o0.clutter_fraction = 0.25;
  const SynthModel m0 = generate(o0);
  const double cross = static_cast<double>(m.truth.plane_edges_in_chart) / static_cast<double>(m.truth.plane_edges);
  const double cross0 = static_cast<double>(m0.truth.plane_edges_in_chart) / static_cast<double>(m0.truth.plane_edges);
  std::printf("exposure sd %.3f; clutter faces %.3f; plane edges inside charts %.3f (cross_plane 0.6) vs %.3f (0)\n", sd,
              clutter, cross, cross0);
  EXPECT_NEAR(sd, 0.1, 0.02);
  EXPECT_NEAR(clutter, 0.25, 0.07);  // faces follow area up to the triangulation of small facets
  EXPECT_GT(cross, cross0 + 0.05);
  size_t veg = 0;
  for (SemanticClass c : m.truth.face_class) veg += c == SemanticClass::Vegetation ? 1 : 0;
  EXPECT_GT(veg, 0u);
  EXPECT_LE(veg, m.truth.clutter_faces);
}

TEST(SynthHard, PresetsAndOptionChecks) {
  SynthOptions o;
  EXPECT_TRUE(apply_preset("hard", o));
  EXPECT_GT(o.mirror_fraction, 0);
  EXPECT_GT(o.clutter_fraction, 0);
  EXPECT_TRUE(apply_preset("default", o));
  EXPECT_EQ(o.mirror_fraction, 0);
  EXPECT_FALSE(apply_preset("easy", o));
  o = base(1);
  o.mirror_fraction = 1.5;
  EXPECT_THROW(generate(o), std::invalid_argument);
  o = base(1);
  o.perspective = 2;
  EXPECT_THROW(generate(o), std::invalid_argument);
}

// The hard preset's realism figures on a small instance (8k faces, ~4 s with the M-method run),
// against the ranges measured on the six real ContextCapture tiles (docs/synth.md, realism table):
// input charts per face 0.10-0.37 (t078_L17 0.097 ... t078_L15 0.367), V2/V3 1.77-3.12. Chart
// reduction of configs/mmethod.json: at least 0.40, since our merger refuses mirrored pairs (40%
// of the faces here; on the hard set 0.5-0.6 until mirrored merges exist, issue 18), and at most
// 0.92, just above the real tiles' 0.84-0.89 of the original program: a preset merged almost
// entirely (issue 18: every method ended at 2-17 charts on the default buildings) is too easy.
TEST(SynthHard, HardPresetLooksLikeTheRealTiles) {
  SynthOptions o;
  ASSERT_TRUE(apply_preset("hard", o));
  o.archetype = Archetype::Hotel;
  o.target_faces = 8000;
  o.seed = 11;
  SynthModel m = generate(o);
  const std::string dir = texdefrag::testing::temp_dir();
  write_model(m, o, dir + "/in");
  const std::string obj = dir + "/in/" + m.name + ".obj";
  const eval::ModelMetrics in = eval::model_metrics(read_obj(obj));
  const double charts_per_face = static_cast<double>(in.charts) / static_cast<double>(in.faces);
  const PipelineConfig cfg = load_config((fs::path(source_dir()) / "configs" / "mmethod.json").string());
  RunOptions ro;
  ro.input = obj;
  ro.output_dir = dir + "/mmethod";
  const json report = run_pipeline(cfg, ro);
  eval::EvalOptions eo;
  eo.texture = false;
  const eval::Comparison c = eval::compare_files(obj, report["output"].get<std::string>(), eo);
  const double reduction = 1.0 - static_cast<double>(c.output.charts) / static_cast<double>(c.input.charts);
  std::printf("hard preset, hotel 8k: charts/face %.3f, V2/V3 %.3f, mmethod chart reduction %.3f (%zu -> %zu)\n",
              charts_per_face, in.vertex_replication, reduction, c.input.charts, c.output.charts);
  EXPECT_GE(charts_per_face, 0.10);
  EXPECT_LE(charts_per_face, 0.37);
  EXPECT_GE(in.vertex_replication, 1.77);
  EXPECT_LE(in.vertex_replication, 3.12);
  EXPECT_GE(reduction, 0.40);
  EXPECT_LE(reduction, 0.92);
  EXPECT_EQ(c.match.lost, 0u);
}

namespace {
/// Directed welded edges used by more than one face: an edge two faces traverse the same way round
/// (inconsistent 3D winding; 0 on a consistently oriented surface).
size_t same_direction_edges(const TexturedMesh& m) {
  const Topology topo = build_topology(m);
  std::map<std::pair<int, int>, int> uses;
  size_t bad = 0;
  for (size_t f = 0; f < m.faces.size(); ++f)
    for (size_t k = 0; k < 3; ++k) {
      const int a = topo.face_vertex[f][k], b = topo.face_vertex[f][(k + 1) % 3];
      if (a != b && ++uses[{a, b}] == 2) ++bad;
    }
  return bad;
}
}  // namespace

// Building `index` of the hard data set `--count count --seed seed --min-faces lo --max-faces hi`,
// without pages.
static SynthModel hard_building(size_t count, uint64_t seed, size_t lo, size_t hi, size_t index) {
  DatasetOptions d;
  d.count = count;
  d.seed = seed;
  d.min_faces = lo;
  d.max_faces = hi;
  d.render_pages = false;
  EXPECT_TRUE(apply_preset("hard", d.base));
  d.preset = "hard";
  const std::vector<SynthOptions> plan = dataset_plan(d);
  EXPECT_EQ(plan.size(), count);
  SynthOptions o = plan.at(index);
  o.render_pages = false;
  return generate(o);
}

// The hard data set `--count 4 --seed 160 --min-faces 15000 --max-faces 40000` drew two chimneys on
// one roof slope of building b0002 (27.5k faces) that overlap: the roof's holes overlapped, the
// even-odd inside test put roof triangles back over their intersection, and 7 of their edges ran
// the same way round as the chimney walls' (found by the merger's mirror_orientation work,
// docs/mergers.md step 3). Chimneys that would overlap an earlier one are not built now.
TEST(SynthHard, OverlappingChimneysAreNotBuiltSoTheWindingIsConsistent) {
  const SynthModel m = hard_building(4, 160, 15000, 40000, 2);
  EXPECT_GT(m.mesh.faces.size(), 20000u);
  EXPECT_EQ(same_direction_edges(m.mesh), 0u);
}

// The hard data set `--count 8 --seed 11 --min-faces 8000 --max-faces 30000` (docs/bench.md), b0003
// (a hotel, 9.5k faces): its balcony openings are 0.2 m high, shorter than the mesh edge, and the
// walls' Delaunay triangulations did not keep the openings' long boundary segments; wall triangles
// reached across them and 16 edges ran the same way round as the slabs'. The remesher now splits
// every boundary segment its polygon's triangulation lost (in every polygon sharing it) and meshes
// again until all are kept (a conforming triangulation).
TEST(SynthHard, ThinBalconySlabsKeepTheirWallsBoundarySoTheWindingIsConsistent) {
  const SynthModel m = hard_building(8, 11, 8000, 30000, 3);
  EXPECT_GT(m.mesh.faces.size(), 8000u);
  EXPECT_EQ(same_direction_edges(m.mesh), 0u);
}
