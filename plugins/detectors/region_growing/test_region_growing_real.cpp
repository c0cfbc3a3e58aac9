// Invariant tests of the detectors on the real ContextCapture tiles (skipped when absent): every
// textured face labelled, region counts sensible; the grouping refinements only join and never make
// a facade+roof/ground region; prints region statistics for the doc page.
#include "common/region_output.h"
#include "common/test_meshes.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>

using namespace texdefrag;
namespace tmesh = texdefrag::detectors::testmesh;

TEST(DetectorsRegionGrowingReal, EveryFaceLabelledAndRegionCountsSensible) {
  const auto models = texdefrag::testing::real_models(50000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  const std::string out = texdefrag::testing::temp_dir();
  for (const std::string& path : models) {
    const TexturedMesh m = read_obj(path);
    size_t textured = 0;
    for (const Face& f : m.faces) textured += f.page != kNoPage;
    for (const char* name : {"detectors.region_growing", "detectors.angle_growing"}) {
      const auto t0 = std::chrono::steady_clock::now();
      const tmesh::Detection d = tmesh::run_detector(name, m);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      ASSERT_EQ(d.regions.face_region.size(), m.faces.size());
      for (size_t f = 0; f < m.faces.size(); ++f) {
        if (m.faces[f].page == kNoPage) continue;
        ASSERT_GE(d.regions.face_region[f], 0) << path << " face " << f;
        ASSERT_LT(d.regions.face_region[f], d.regions.num_regions);
      }
      EXPECT_GE(d.regions.num_regions, 1);
      // note: only region growing is held to a sensible count; plain angle growing fragments real
      // photogrammetric noise into mostly single faces (that is the paper's point), it is printed only.
      if (std::string(name) == "detectors.region_growing") {
        EXPECT_LT(static_cast<size_t>(d.regions.num_regions), textured / 10) << path;
        EXPECT_LT(d.report["largest_region_fraction"].get<double>(), 0.9) << path;  // not one blob
      }
      std::printf("%s %s: %zu faces, %s, incl. topology+charts %.3f s\n", name,
                  std::filesystem::path(path).filename().c_str(), m.faces.size(), d.report.dump().c_str(), s);
      if (std::string(name) == "detectors.region_growing")
        detectors::write_colored_model(name, out + "/" + std::filesystem::path(path).stem().string() + "_regions.obj", m,
                                       d.regions);
    }
  }
}

namespace {

/// Regions (with at least 50 faces) holding at least 30% of their area in near-vertical faces
/// (normal within 20 degrees of horizontal: walls) and 30% in near-horizontal faces (within 20
/// degrees of vertical: roofs, ground): a facade joined with a roof or the ground. Raw face
/// normals; the tiles' z axis is up.
int wall_and_flat_regions(const TexturedMesh& m, const Regions& r) {
  std::vector<std::array<double, 3>> acc(static_cast<size_t>(r.num_regions), {0, 0, 0});  // wall, flat, all
  std::vector<int> faces(static_cast<size_t>(r.num_regions), 0);
  for (size_t f = 0; f < m.faces.size(); ++f) {
    const int g = r.face_region[f];
    if (g < 0) continue;
    const Vec3 n = face_normal(m, f);
    const double a = face_area_3d(m, f);
    if (!(a > 0)) continue;
    const double nz = std::abs(n.z());
    auto& c = acc[static_cast<size_t>(g)];
    c[0] += nz < std::sin(20 * M_PI / 180) ? a : 0;
    c[1] += nz > std::cos(20 * M_PI / 180) ? a : 0;
    c[2] += a;
    ++faces[static_cast<size_t>(g)];
  }
  int mixed = 0;
  for (size_t g = 0; g < acc.size(); ++g)
    mixed += faces[g] >= 50 && acc[g][0] >= 0.3 * acc[g][2] && acc[g][1] >= 0.3 * acc[g][2];
  return mixed;
}

}  // namespace

TEST(DetectorsRegionGrowingReal, CoplanarAndCurvedGroupingOnlyJoinAndNeverJoinFacadesWithRoofsOrGround) {
  const auto models = texdefrag::testing::real_models(50000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  for (const std::string& path : models) {
    const TexturedMesh m = read_obj(path);
    const tmesh::Detection on = tmesh::run_detector("detectors.region_growing", m);
    const tmesh::Detection off = tmesh::run_detector("detectors.region_growing", m,
                                                     {{"coplanar_grouping", false}, {"curved_surfaces", false}});
    const int mixed_on = wall_and_flat_regions(m, on.regions), mixed_off = wall_and_flat_regions(m, off.regions);
    std::printf("%s: regions %d -> %d (coplanar joins %d, across speckle %d, speckle %d, cylinder joins %d), "
                "largest %.3f -> %.3f, facade+flat regions %d -> %d\n",
                std::filesystem::path(path).filename().c_str(), off.regions.num_regions, on.regions.num_regions,
                on.report["coplanar_joins"].get<int>(), on.report["coplanar_joins_across_speckle"].get<int>(),
                on.report["coplanar_speckle_absorbed"].get<int>(), on.report["cylinder_joins"].get<int>(),
                off.report["largest_region_fraction"].get<double>(), on.report["largest_region_fraction"].get<double>(),
                mixed_off, mixed_on);
    EXPECT_LE(on.regions.num_regions, off.regions.num_regions) << path;
    EXPECT_LE(mixed_on, mixed_off) << path;
    // Nothing swallows the tile: the largest region grows by at most half.
    EXPECT_LE(on.report["largest_region_fraction"].get<double>(),
              1.5 * off.report["largest_region_fraction"].get<double>()) << path;
  }
}
