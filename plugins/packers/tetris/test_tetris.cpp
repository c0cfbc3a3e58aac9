// packers.tetris: created by name; invariants, outline nesting (raster profiles, 4 rotations),
// real tiles.
#include "pack_test_support.h"

#include "texdefrag/stage/registry.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace texdefrag;
using namespace texdefrag::packtest;

namespace {
const std::string kName = "packers.tetris";
}

TEST(PackersTetris, Registered) {
  Registry::instance().load_plugins();
  const StageInfo* info = Registry::instance().find(kName);
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->kind, StageKind::Packer);
}

TEST(PackersTetris, Invariants) { packer_invariant_suite(kName); }

TEST(PackersTetris, NestsTrianglesByOutline) {
  // Two right triangles with 100-texel legs: bounding boxes alone need 2 x 105^2 texels; the
  // rasterised outlines nest (one turned by 180 degrees) into about one box.
  const std::vector<std::vector<Vec2>> polys = {{{0, 0}, {100, 0}, {0, 100}}, {{200, 0}, {300, 0}, {200, 100}}};
  auto run = run_packer(kName, polygon_mesh(polys, 1024));
  expect_valid_layout(*run, 4);
  const auto& p = run->ctx.layout.pages.at(0);
  EXPECT_LT(static_cast<double>(p.width) * p.height, 2.0 * 105 * 105);
  EXPECT_GE(run->report.at("charts_turned_90").get<int>(), 1);
  EXPECT_EQ(exact_chart_fraction(*run), 1.0);
}

TEST(PackersTetris, NoRotationKeepsOrientation) {
  std::mt19937 rng(2);
  auto run = run_packer(kName, polygon_mesh(random_polygons(rng, 100, 2, 40, 1024), 1024), {{"allow_rotation", false}});
  expect_valid_layout(*run, 4);
  EXPECT_EQ(run->report.at("charts_turned_90").get<int>(), 0);
  // Every chart moved by an integer vector only.
  const Atlas& a = run->ctx.atlas;
  for (size_t f = 0; f < a.face_chart.size(); ++f)
    for (int w : a.face_wedge[f]) {
      const Vec2 d = run->ctx.layout.wedge_uv[static_cast<size_t>(w)] - a.wedge_uv[static_cast<size_t>(w)];
      EXPECT_NEAR(d.x(), std::round(d.x()), 1e-9);
      EXPECT_NEAR(d.y(), std::round(d.y()), 1e-9);
    }
}

TEST(PackersTetris, RealTiles) {
  const auto res = packer_real_suite(kName, 10000);
  if (res.empty()) GTEST_SKIP() << "no real models";
  for (const auto& r : res) std::cout << kName << " " << r.first << " efficiency " << r.second << "\n";
}
