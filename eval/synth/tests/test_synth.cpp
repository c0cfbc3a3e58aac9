// Tests of the synthetic benchmark generator (eval/synth, issue 3).
#include "texdefrag/synth/synth.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <array>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::synth;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

SynthOptions small(Archetype a, size_t faces, uint64_t seed, bool render = false) {
  SynthOptions o;
  o.archetype = a;
  o.target_faces = faces;
  o.seed = seed;
  o.render_pages = render;
  return o;
}

/// Chart statistics compared between generated and real models (METHOD.md section 3).
struct Fragmentation {
  double median_faces = 0;     ///< median faces per chart
  double single_share = 0;     ///< share of charts with one face
  double replication = 0;      ///< V2 / V3
  double occupancy = 0;        ///< chart UV area / page area
  size_t faces = 0, charts = 0;
};

Fragmentation fragmentation(const TexturedMesh& m) {
  const Topology topo = build_topology(m);
  const ChartSet cs = build_charts(m, topo);
  Fragmentation r;
  r.faces = m.faces.size();
  r.charts = cs.stats.size();
  std::vector<int> sizes;
  double uv = 0;
  for (const ChartStats& s : cs.stats) {
    sizes.push_back(s.faces);
    uv += s.uv_area;
  }
  std::sort(sizes.begin(), sizes.end());
  const size_t n = sizes.size();
  r.median_faces = n % 2 ? sizes[n / 2] : 0.5 * (sizes[n / 2 - 1] + sizes[n / 2]);
  r.single_share = static_cast<double>(std::count(sizes.begin(), sizes.end(), 1)) / static_cast<double>(n);
  std::set<std::tuple<int, double, double, int>> corners;
  for (size_t f = 0; f < m.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2& t = m.texcoords[static_cast<size_t>(m.faces[f].vt[static_cast<size_t>(k)])];
      corners.emplace(topo.face_vertex[f][static_cast<size_t>(k)], t.x(), t.y(), m.faces[f].page);
    }
  r.replication = static_cast<double>(corners.size()) / static_cast<double>(topo.report.welded_vertices);
  double page_area = 0;
  for (const Page& p : m.pages) page_area += static_cast<double>(p.width) * p.height;
  r.occupancy = uv / page_area;
  return r;
}

void print(const char* what, const Fragmentation& f) {
  std::printf("  %-44s F=%6zu charts=%5zu median=%4.1f single=%.3f V2/V3=%.3f occupancy=%.3f\n", what, f.faces,
              f.charts, f.median_faces, f.single_share, f.replication, f.occupancy);
}


/// Renders faces coloured by chart (orthographic view from the south-west, 40 degrees up, z-buffer)
/// into a size x size panel of `img` at column offset x_off. Returns the number of covered pixels.
size_t render_charts(const TexturedMesh& m, Image& img, int x_off, int size) {
  const Topology topo = build_topology(m);
  const ChartSet cs = build_charts(m, topo);
  const double az = 3.141592653589793 * 1.25, el = 3.141592653589793 * 40 / 180;
  const Vec3 view(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), -std::sin(el));  // looking along
  const Vec3 right = view.cross(Vec3::UnitZ()).normalized(), up = right.cross(view);
  Vec2 lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const Vec3& p : m.positions) {
    const Vec2 q(p.dot(right), p.dot(up));
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const double s = (size - 4) / std::max(hi.x() - lo.x(), hi.y() - lo.y());
  std::vector<double> depth(static_cast<size_t>(size) * static_cast<size_t>(size), 1e300);
  size_t covered = 0;
  for (size_t f = 0; f < m.faces.size(); ++f) {
    Vec2 q[3];
    double d[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = m.corner_position(f, k);
      q[k] = Vec2(2 + (p.dot(right) - lo.x()) * s, 2 + (hi.y() - p.dot(up)) * s);
      d[k] = p.dot(view);
    }
    const double area = (q[1] - q[0]).x() * (q[2] - q[0]).y() - (q[1] - q[0]).y() * (q[2] - q[0]).x();
    if (std::abs(area) < 1e-12) continue;
    const uint64_t h = static_cast<uint64_t>(cs.atlas.face_chart[f] + 1) * 0x9E3779B97F4A7C15ull;
    const uint8_t col[3] = {static_cast<uint8_t>(60 + (h >> 40) % 190), static_cast<uint8_t>(60 + (h >> 48) % 190),
                            static_cast<uint8_t>(60 + (h >> 56) % 190)};
    const int x0 = std::max(0, static_cast<int>(std::min({q[0].x(), q[1].x(), q[2].x()})));
    const int x1 = std::min(size - 1, static_cast<int>(std::max({q[0].x(), q[1].x(), q[2].x()})));
    const int y0 = std::max(0, static_cast<int>(std::min({q[0].y(), q[1].y(), q[2].y()})));
    const int y1 = std::min(size - 1, static_cast<int>(std::max({q[0].y(), q[1].y(), q[2].y()})));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Vec2 c(x + 0.5, y + 0.5);
        double b[3];
        for (int k = 0; k < 3; ++k) {
          const Vec2 e = q[(k + 2) % 3] - q[(k + 1) % 3], r = c - q[(k + 1) % 3];
          b[k] = (e.x() * r.y() - e.y() * r.x()) / area;
        }
        if (b[0] < 0 || b[1] < 0 || b[2] < 0) continue;
        const double z = b[0] * d[0] + b[1] * d[1] + b[2] * d[2];
        double& zb = depth[static_cast<size_t>(y) * static_cast<size_t>(size) + static_cast<size_t>(x)];
        if (z >= zb) continue;
        if (zb == 1e300) ++covered;
        zb = z;
        std::copy(col, col + 3, img.at(x_off + x, y));
      }
  }
  return covered;
}
}  // namespace

TEST(Synth, ParsesArchetypeNames) {
  for (Archetype a : {Archetype::Residential, Archetype::Factory, Archetype::Hotel, Archetype::LShape,
                      Archetype::Courtyard, Archetype::Mixed})
    EXPECT_EQ(parse_archetype(to_string(a)), a);
  EXPECT_FALSE(parse_archetype("castle").has_value());
}

TEST(Synth, RejectsBadOptions) {
  SynthOptions o = small(Archetype::Residential, 5000, 1);
  o.target_faces = 10;
  EXPECT_THROW(generate(o), std::invalid_argument);
  o = small(Archetype::Residential, 5000, 1);
  o.page_size = 1000;
  EXPECT_THROW(generate(o), std::invalid_argument);
  o = small(Archetype::Residential, 5000, 1);
  o.noise_cm = -1;
  EXPECT_THROW(generate(o), std::invalid_argument);
}

TEST(Synth, SameSeedGivesIdenticalFiles) {
  const std::string dir = texdefrag::testing::temp_dir();
  SynthOptions o = small(Archetype::Mixed, 5000, 42, true);
  for (const char* sub : {"a", "b"}) {
    SynthModel m = generate(o);
    write_model(m, o, (fs::path(dir) / sub).string());
  }
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "a")) {
    const fs::path other = fs::path(dir) / "b" / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(slurp(e.path()), slurp(other)) << e.path().filename();
    ++files;
  }
  EXPECT_GE(files, 4u);  // obj, mtl, truth, at least one page
  // a different seed gives a different model
  o.seed = 43;
  const SynthModel other = generate(o);
  const SynthModel first = generate(small(Archetype::Mixed, 5000, 42));
  EXPECT_FALSE(first.mesh.faces.size() == other.mesh.faces.size() &&
               first.mesh.positions.front() == other.mesh.positions.front());
}

TEST(Synth, FaceCountsNearRequestForEveryArchetype) {
  for (Archetype a : {Archetype::Residential, Archetype::Factory, Archetype::Hotel, Archetype::LShape, Archetype::Courtyard}) {
    for (size_t target : {6000u, 15000u}) {
      const SynthModel m = generate(small(a, target, 7));
      const double rel = std::abs(static_cast<double>(m.mesh.faces.size()) - static_cast<double>(target)) / static_cast<double>(target);
      EXPECT_LT(rel, 0.08) << to_string(a) << " target " << target << " got " << m.mesh.faces.size();
      EXPECT_EQ(m.truth.archetype, to_string(a));
      // edge length of a multi-view-stereo mesh (small requests on big archetypes are coarser)
      if (target >= 15000) {
        EXPECT_GT(m.truth.mean_edge_m, 0.1) << to_string(a);
        EXPECT_LT(m.truth.mean_edge_m, 1.3) << to_string(a);
      }
    }
  }
}

TEST(Synth, EveryFaceHasTruthAndValidUVs) {
  const SynthModel m = generate(small(Archetype::Hotel, 8000, 5));
  const SynthTruth& t = m.truth;
  const size_t F = m.mesh.faces.size();
  ASSERT_EQ(t.face_plane.size(), F);
  ASSERT_EQ(t.face_class.size(), F);
  ASSERT_EQ(t.face_view.size(), F);
  ASSERT_EQ(t.face_chart.size(), F);
  std::set<SemanticClass> classes;
  for (size_t f = 0; f < F; ++f) {
    ASSERT_GE(t.face_plane[f], 0);
    ASSERT_LT(static_cast<size_t>(t.face_plane[f]), t.planes.size());
    EXPECT_EQ(t.face_class[f], t.planes[static_cast<size_t>(t.face_plane[f])].semantic);
    ASSERT_GE(t.face_view[f], 0);
    ASSERT_LT(static_cast<size_t>(t.face_view[f]), t.cameras.size());
    classes.insert(t.face_class[f]);
    const Face& fc = m.mesh.faces[f];
    ASSERT_NE(fc.page, kNoPage);
    for (int k = 0; k < 3; ++k) {
      const Vec2& uv = m.mesh.texcoords[static_cast<size_t>(fc.vt[static_cast<size_t>(k)])];
      ASSERT_TRUE(std::isfinite(uv.x()) && std::isfinite(uv.y()));
      EXPECT_GT(uv.x(), 0.0);
      EXPECT_LT(uv.x(), 1.0);
      EXPECT_GT(uv.y(), 0.0);
      EXPECT_LT(uv.y(), 1.0);
      ASSERT_TRUE(m.mesh.positions[static_cast<size_t>(fc.v[static_cast<size_t>(k)])].allFinite());
    }
  }
  EXPECT_EQ(classes.size(), 4u);  // wall, roof, ground and detail all present
  // nadir and oblique cameras, principal point on the optical axis
  std::set<std::string> kinds;
  for (const Camera& c : t.cameras) kinds.insert(c.kind.substr(0, 7));
  EXPECT_TRUE(kinds.count("nadir") && kinds.count("oblique"));
}

namespace {
/// Whether the camera of face f's view sees it from behind (its 3D winding's normal points away).
bool seen_from_behind(const SynthModel& m, size_t f) {
  const Face& fc = m.mesh.faces[f];
  const Vec3& a = m.mesh.positions[static_cast<size_t>(fc.v[0])];
  const Vec3& b = m.mesh.positions[static_cast<size_t>(fc.v[1])];
  const Vec3& c = m.mesh.positions[static_cast<size_t>(fc.v[2])];
  const Camera& cam = m.truth.cameras[static_cast<size_t>(m.truth.face_view[f])];
  return (b - a).cross(c - a).dot(cam.position - (a + b + c) / 3.0) < 0;
}

/// Signed UV area (texels^2) of face f.
double uv_turn(const SynthModel& m, size_t f) {
  const Vec2 a = m.mesh.corner_texel(f, 0), b = m.mesh.corner_texel(f, 1), c = m.mesh.corner_texel(f, 2);
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}
}  // namespace

TEST(Synth, ChartsAreTheConnectedSameViewComponents) {
  for (Archetype a : {Archetype::Residential, Archetype::Courtyard}) {
    const SynthModel m = generate(small(a, 6000, 11));
    const Topology topo = build_topology(m.mesh);
    const ChartSet cs = build_charts(m.mesh, topo);
    ASSERT_EQ(cs.atlas.face_chart.size(), m.mesh.faces.size());
    EXPECT_EQ(cs.stats.size(), static_cast<size_t>(m.truth.num_charts)) << to_string(a);
    // the two partitions are the same: a bijection between chart ids
    std::map<int, int> fwd, back;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      const int c = cs.atlas.face_chart[f], t = m.truth.face_chart[f];
      auto [it, fresh] = fwd.emplace(c, t);
      EXPECT_EQ(it->second, t) << "face " << f;
      auto [it2, fresh2] = back.emplace(t, c);
      EXPECT_EQ(it2->second, c) << "face " << f;
    }
    // every chart has one view, and neighbouring faces with the same view, seen from the same side of
    // it, share a chart
    std::map<int, int> view_of_chart;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      auto [it, fresh] = view_of_chart.emplace(m.truth.face_chart[f], m.truth.face_view[f]);
      EXPECT_EQ(it->second, m.truth.face_view[f]);
    }
    for (size_t f = 0; f < m.mesh.faces.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int g = topo.opposite_face(static_cast<int>(f), k);
        if (g >= 0 && m.truth.face_view[f] == m.truth.face_view[static_cast<size_t>(g)] &&
            seen_from_behind(m, f) == seen_from_behind(m, static_cast<size_t>(g))) {
          EXPECT_EQ(m.truth.face_chart[f], m.truth.face_chart[static_cast<size_t>(g)]);
        }
      }
    // labels cross plane boundaries: some chart holds faces of two planes
    std::map<int, std::set<int>> planes_of_chart;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) planes_of_chart[m.truth.face_chart[f]].insert(m.truth.face_plane[f]);
    size_t crossing = 0;
    for (const auto& [c, p] : planes_of_chart) crossing += p.size() > 1;
    EXPECT_GT(crossing, 0u);
    // the mesh joins planes: few boundary edges relative to all edges
    EXPECT_LT(static_cast<double>(topo.report.boundary_edges), 0.05 * static_cast<double>(topo.report.edges));
  }
}

// Real producers' UVs turn like the faces' 3D winding (the six ContextCapture development tiles: 0-3
// faces of 23k the other way; a whole chart may be mirrored, never a face inside a chart). Faces that
// no camera sees from the front (undersides of eaves and balconies) take a camera that sees them from
// behind, whose projection turns the other way: such faces make charts of their own, mirrored back.
// Before 2026-12-05 they sat inside their neighbours' charts as input folds (1-3% of the faces).
TEST(Synth, EveryFaceTurnsLikeItsWindingAndFacesSeenFromBehindHaveTheirOwnCharts) {
  for (Archetype a : {Archetype::Residential, Archetype::Hotel}) {
    const SynthModel m = generate(small(a, 6000, 11));
    size_t behind = 0, against = 0;
    for (size_t f = 0; f < m.mesh.faces.size(); ++f) {
      against += uv_turn(m, f) < 0 ? 1 : 0;  // the generator's faces turn positive (v up), all of them
      behind += seen_from_behind(m, f) ? 1 : 0;
    }
    EXPECT_EQ(against, 0u) << to_string(a);
    EXPECT_GT(behind, 0u) << to_string(a) << ": the case is not exercised";
    const Topology topo = build_topology(m.mesh);
    for (size_t f = 0; f < m.mesh.faces.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int g = topo.opposite_face(static_cast<int>(f), k);
        if (g >= 0 && seen_from_behind(m, f) != seen_from_behind(m, static_cast<size_t>(g))) {
          EXPECT_NE(m.truth.face_chart[f], m.truth.face_chart[static_cast<size_t>(g)]) << "face " << f;
        }
      }
  }
}

TEST(Synth, WrittenModelReadsBack) {
  const std::string dir = texdefrag::testing::temp_dir();
  SynthOptions o = small(Archetype::Factory, 5000, 3, true);
  SynthModel m = generate(o);
  write_model(m, o, dir);
  const TexturedMesh back = read_obj((fs::path(dir) / (m.name + ".obj")).string());
  ASSERT_EQ(back.faces.size(), m.mesh.faces.size());
  ASSERT_EQ(back.pages.size(), m.mesh.pages.size());
  for (size_t k = 0; k < back.pages.size(); ++k) {
    EXPECT_EQ(back.pages[k].width, m.mesh.pages[k].width);
    EXPECT_EQ(back.pages[k].height, m.mesh.pages[k].height);
  }
  for (size_t f = 0; f < back.faces.size(); f += 97)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(back.corner_position(f, k), m.mesh.corner_position(f, k));
  // pages are not blank: texels under charts carry colour
  const Image img = read_image(back.pages[0].image_path);
  size_t lit = 0;
  for (size_t i = 0; i < img.pixels.size(); ++i) lit += img.pixels[i] > 20;
  EXPECT_GT(lit, img.pixels.size() / 20);
  // the truth sidecar matches the mesh
  std::ifstream f(fs::path(dir) / (m.name + ".truth.json"));
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j["faces"].get<size_t>(), back.faces.size());
  EXPECT_EQ(j["face_plane"].size(), back.faces.size());
  EXPECT_EQ(j["face_view"].size(), back.faces.size());
  EXPECT_EQ(j["cameras"].size(), m.truth.cameras.size());
}

TEST(Synth, DatasetWritesManifest) {
  const std::string dir = texdefrag::testing::temp_dir();
  DatasetOptions d;
  d.count = 3;
  d.seed = 9;
  d.min_faces = 2000;
  d.max_faces = 4000;
  d.render_pages = false;
  const auto plan = dataset_plan(d);
  ASSERT_EQ(plan.size(), 3u);
  for (const auto& o : plan) {
    EXPECT_GE(o.target_faces, 2000u);
    EXPECT_LE(o.target_faces, 4000u);
  }
  const nlohmann::json man = write_dataset(d, dir);
  ASSERT_EQ(man["models"].size(), 3u);
  for (const auto& e : man["models"]) {
    EXPECT_TRUE(fs::exists(fs::path(dir) / e["obj"].get<std::string>()));
    EXPECT_TRUE(fs::exists(fs::path(dir) / e["truth"].get<std::string>()));
  }
  EXPECT_TRUE(fs::exists(fs::path(dir) / "manifest.json"));
  d.max_faces = 1000;
  EXPECT_THROW(dataset_plan(d), std::invalid_argument);
}

// The realism check of issue 3: chart statistics of generated buildings against the real
// ContextCapture tiles. Each statistic's generated range must overlap the real range.
TEST(Synth, ChartStatisticsOverlapRealContextCaptureTiles) {
  std::vector<std::string> real;
  for (const std::string& p : texdefrag::testing::real_models(30000))
    if (p.find("contextcapture") != std::string::npos) real.push_back(p);
  if (real.empty()) GTEST_SKIP() << "no ContextCapture tiles under ../shared/data";
  std::printf("real ContextCapture tiles:\n");
  std::vector<Fragmentation> rs, gs;
  for (const std::string& p : real) {
    ObjReadOptions ro;
    rs.push_back(fragmentation(read_obj(p, ro)));
    print(fs::path(p).filename().string().c_str(), rs.back());
  }
  std::printf("generated:\n");
  int i = 0;
  for (Archetype a : {Archetype::Residential, Archetype::Factory, Archetype::Hotel, Archetype::LShape, Archetype::Courtyard}) {
    const SynthModel m = generate(small(a, i % 2 ? 12000 : 8000, 100 + static_cast<uint64_t>(i)));
    gs.push_back(fragmentation(m.mesh));
    print(m.name.c_str(), gs.back());
    ++i;
  }
  auto overlap = [&](const char* what, double Fragmentation::*field) {
    double rlo = 1e300, rhi = -1e300, glo = 1e300, ghi = -1e300;
    for (const auto& r : rs) {
      rlo = std::min(rlo, r.*field);
      rhi = std::max(rhi, r.*field);
    }
    for (const auto& g : gs) {
      glo = std::min(glo, g.*field);
      ghi = std::max(ghi, g.*field);
    }
    std::printf("  %-14s real [%.3f, %.3f]  generated [%.3f, %.3f]\n", what, rlo, rhi, glo, ghi);
    EXPECT_TRUE(glo <= rhi && rlo <= ghi) << what << ": generated [" << glo << ", " << ghi << "] vs real [" << rlo
                                          << ", " << rhi << "]";
  };
  overlap("median faces", &Fragmentation::median_faces);
  overlap("single share", &Fragmentation::single_share);
  overlap("V2/V3", &Fragmentation::replication);
  overlap("occupancy", &Fragmentation::occupancy);
}

// Chart-coloured pictures of a generated building and a real tile side by side, for a person to
// judge (issue 3). The PNG path is printed; the test checks that both panels show many charts.
TEST(Synth, WritesChartPictureBesideARealTile) {
  const int size = 512;
  Image img;
  img.width = 2 * size;
  img.height = size;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 255);
  const SynthModel m = generate(small(Archetype::Hotel, 12000, 21));
  const size_t gen = render_charts(m.mesh, img, 0, size);
  EXPECT_GT(gen, static_cast<size_t>(size * size / 10));
  std::vector<std::string> real;
  for (const std::string& p : texdefrag::testing::real_models(30000))
    if (p.find("prod5_t017") != std::string::npos) real.push_back(p);
  if (!real.empty()) {
    const size_t got = render_charts(read_obj(real[0]), img, size, size);
    EXPECT_GT(got, static_cast<size_t>(size * size / 10));
  }
  std::set<std::array<uint8_t, 3>> colours;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) colours.insert({img.at(x, y)[0], img.at(x, y)[1], img.at(x, y)[2]});
  EXPECT_GT(colours.size(), 100u);  // many distinct charts visible on the generated building
  const std::string path = (fs::path(texdefrag::testing::temp_dir()) / "charts_synth_vs_real.png").string();
  write_image(path, img, ImageFormat::Png);
  std::printf("chart pictures (left generated %s, right real tile): %s\n", m.name.c_str(), path.c_str());
}
