// packers.square_tetris: created by name; invariants, hole filling, free rotation of merged charts,
// efficiency against the other packers on building-like charts, real tiles.
#include "pack_test_support.h"

#include "texdefrag/packers/geometry.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <thread>

#include <gtest/gtest.h>

using namespace texdefrag;
using namespace texdefrag::packtest;

namespace {
const std::string kName = "packers.square_tetris";
}

TEST(PackersSquareTetris, RegisteredWithCommonOptions) {
  Registry::instance().load_plugins();
  const StageInfo* info = Registry::instance().find(kName);
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->kind, StageKind::Packer);
  std::vector<std::string> keys;
  for (const auto& o : info->options) keys.push_back(o.key);
  for (const char* k : {"gutter", "max_page_size", "page_multiple", "power_of_two", "allow_rotation", "free_rotation",
                        "rotation_gain", "exact_fraction", "width_trials"})
    EXPECT_NE(std::find(keys.begin(), keys.end(), k), keys.end()) << k;
}

TEST(PackersSquareTetris, Invariants) { packer_invariant_suite(kName); }

TEST(PackersSquareTetris, WidthTrialsSideBySideGiveTheSameLayoutForAnyThreadCount) {
  // Building-like charts on one page: several widths pack them on a single page, and the trials
  // run side by side with 2 and 4 threads stop each other early (TrialBoard); the chosen width and
  // every placement must be those of one thread.
  std::mt19937 rng(7);
  const auto polys = building_polygons(rng, 220, 2048);
  std::vector<std::unique_ptr<PackRun>> runs;
  for (int threads : {1, 2, 4}) {
    set_thread_count(threads);
    runs.push_back(run_packer(kName, polygon_mesh(polys, 2048), {{"width_trials", 5}}));
  }
  set_thread_count(0);
  for (size_t k = 1; k < runs.size(); ++k) {
    EXPECT_EQ(runs[k]->report.at("page_sizes"), runs[0]->report.at("page_sizes"));
    EXPECT_EQ(runs[k]->ctx.layout.wedge_uv, runs[0]->ctx.layout.wedge_uv);
    EXPECT_EQ(runs[k]->ctx.layout.chart_page, runs[0]->ctx.layout.chart_page);
  }
  expect_valid_layout(*runs[0], 4);
}

TEST(PackersSquareTetris, FillsEnclosedSpaces) {
  // A tall and a short rectangle side by side leave a step; the next wide rectangle bridges the
  // step and encloses the space above the short one, which the small squares then fill.
  const std::vector<std::vector<Vec2>> polys = {
      {{0, 0}, {100, 0}, {100, 200}, {0, 200}},        // 101 x 201 cells
      {{0, 0}, {150, 0}, {150, 100}, {0, 100}},        // 151 x 101
      {{0, 0}, {250, 0}, {250, 20}, {0, 20}},          // 251 x 21
      {{0, 0}, {30, 0}, {30, 30}, {0, 30}},
      {{0, 0}, {30, 0}, {30, 30}, {0, 30}},
      {{0, 0}, {30, 0}, {30, 30}, {0, 30}},
  };
  auto run = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 0}});
  expect_valid_layout(*run, 4);
  EXPECT_GE(run->report.at("hole_fills").get<int>(), 1);
}

TEST(PackersSquareTetris, FreeRotationOfMergedChart) {
  // Chart 0 was "merged": its atlas UVs are the input rotated by 0.4 rad. Square Tetris rotates it
  // back to its minimum-area rectangle (200 x 40); the untouched chart 1 stays exact.
  const std::vector<std::vector<Vec2>> polys = {{{100, 100}, {300, 100}, {300, 140}, {100, 140}},
                                                {{400, 400}, {420, 400}, {420, 420}, {400, 420}}};
  auto edit = [](Atlas& a) {
    std::vector<uint8_t> done(a.wedge_uv.size(), 0);
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] == 0)
        for (int w : a.face_wedge[f])
          if (!done[static_cast<size_t>(w)]++) a.wedge_uv[static_cast<size_t>(w)] = packing::rotate(a.wedge_uv[static_cast<size_t>(w)], 0.4);
  };
  auto run = run_packer(kName, polygon_mesh(polys, 1024), json::object(), edit);
  expect_valid_layout(*run, 4);
  EXPECT_EQ(run->report.at("charts_rotated_free").get<int>(), 1);
  EXPECT_EQ(run->report.at("charts_exact").get<int>(), 1);
  // The rotated chart's output is axis-aligned again: its bounding box is 200 x 40 (in some order).
  const Layout& L = run->ctx.layout;
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (size_t f = 0; f < run->ctx.atlas.face_chart.size(); ++f)
    if (run->ctx.atlas.face_chart[f] == 0)
      for (int w : run->ctx.atlas.face_wedge[f]) {
        const Vec2& p = L.wedge_uv[static_cast<size_t>(w)];
        x0 = std::min(x0, p.x()); x1 = std::max(x1, p.x());
        y0 = std::min(y0, p.y()); y1 = std::max(y1, p.y());
      }
  EXPECT_NEAR(std::max(x1 - x0, y1 - y0), 200.0, 1e-6);
  EXPECT_NEAR(std::min(x1 - x0, y1 - y0), 40.0, 1e-6);
  // Without free rotation the box stays the rotated one's (larger).
  auto fixed = run_packer(kName, polygon_mesh(polys, 1024), {{"free_rotation", false}}, edit);
  expect_valid_layout(*fixed, 4);
  EXPECT_EQ(fixed->report.at("charts_rotated_free").get<int>(), 0);
}

TEST(PackersSquareTetris, BeatsTetrisShelfAndRectanglesOnBuildingCharts) {
  std::mt19937 rng(5);
  const auto polys = building_polygons(rng, 600, 4096);
  auto st = run_packer(kName, polygon_mesh(polys, 4096));
  expect_valid_layout(*st, 4);
  const double e_st = layout_efficiency(*st);
  auto te = run_packer("packers.tetris", polygon_mesh(polys, 4096));
  const double e_te = layout_efficiency(*te);
  EXPECT_GE(e_st, e_te);
  // The default outline tail packs at least as well as the paper's rectangles only (tail_side 0).
  auto rect = run_packer(kName, polygon_mesh(polys, 4096), {{"tail_side", 0}});
  expect_valid_layout(*rect, 4);
  const double e_rect = layout_efficiency(*rect);
  EXPECT_GE(e_st, e_rect);
  std::cout << "building charts: square_tetris tail_side 0 " << e_rect << "\n";
  if (Registry::instance().find("packers.shelf")) {
    auto sh = run_packer("packers.shelf", polygon_mesh(polys, 4096));
    EXPECT_GE(e_st, layout_efficiency(*sh));
    std::cout << "building charts: square_tetris " << e_st << " tetris " << e_te << " shelf " << layout_efficiency(*sh) << "\n";
  }
  RecordProperty("efficiency_square_tetris", std::to_string(e_st));
  RecordProperty("efficiency_tetris", std::to_string(e_te));
}

TEST(PackersSquareTetris, RealTiles) {
  const auto res = packer_real_suite(kName, 10000);
  if (res.empty()) GTEST_SKIP() << "no real models";
  for (const auto& r : res) std::cout << kName << " " << r.first << " efficiency " << r.second << "\n";
}

TEST(PackersSquareTetris, OutlineTailNestsSmallCharts) {
  // Two right triangles with 100-texel legs: as rectangles they need two 104 x 104 padded boxes
  // side by side (at least 208 x 104 texels); in the outline tail (tail_side 200 > 104) the second
  // one, turned by 180 degrees, nests against the first's hypotenuse, so the page is smaller.
  const std::vector<std::vector<Vec2>> polys = {{{0, 0}, {100, 0}, {0, 100}}, {{200, 0}, {300, 0}, {200, 100}}};
  auto rect = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 0}});
  expect_valid_layout(*rect, 4);
  EXPECT_EQ(rect->report.at("outline_drops").get<int>(), 0);
  auto tail = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 200}});
  expect_valid_layout(*tail, 4);
  EXPECT_EQ(tail->report.at("outline_drops").get<int>(), 2);
  EXPECT_EQ(exact_chart_fraction(*tail), 1.0);
  auto area = [](const PackRun& r) {
    double a = 0;
    for (const auto& p : r.ctx.layout.pages) a += static_cast<double>(p.width) * p.height;
    return a;
  };
  EXPECT_GE(area(*rect), 208.0 * 104.0);
  EXPECT_LT(area(*tail), area(*rect));
}

TEST(PackersSquareTetris, OutlineTailIsSkippedBeyondTailMaxCharts) {
  // The same two triangles with tail_max_charts 1: the tail would hold 2 charts, so the bottom-left
  // search is skipped and both are dropped on the horizon by their outline profiles (the second
  // turned to nest against the first: less page than as rectangles); with the limit at 2 the
  // search runs.
  const std::vector<std::vector<Vec2>> polys = {{{0, 0}, {100, 0}, {0, 100}}, {{200, 0}, {300, 0}, {200, 100}}};
  auto skipped = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 200}, {"tail_max_charts", 1}});
  expect_valid_layout(*skipped, 4);
  EXPECT_EQ(skipped->report.at("outline_drops").get<int>(), 2);
  EXPECT_EQ(skipped->report.at("tail_charts").get<int>(), 2);
  EXPECT_TRUE(skipped->report.at("outline_tail_skipped").get<bool>());
  auto kept = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 200}, {"tail_max_charts", 2}});
  EXPECT_EQ(kept->report.at("outline_drops").get<int>(), 2);
  EXPECT_FALSE(kept->report.at("outline_tail_skipped").get<bool>());
  auto rects = run_packer(kName, polygon_mesh(polys, 1024), {{"width_trials", 1}, {"tail_side", 0}});
  auto area = [](const PackRun& r) {
    double a = 0;
    for (const auto& p : r.ctx.layout.pages) a += static_cast<double>(p.width) * p.height;
    return a;
  };
  EXPECT_LT(area(*skipped), area(*rects));
}

TEST(PackersSquareTetris, BigIrregularChartsPackedByOutline) {
  // Four L-shaped charts of 600 x 600 texels (box over tail_side^2 = 512^2, outline filling 0.30
  // of the box): as rectangles each takes a whole box; by outline (rect_min_fill 0.75, default)
  // they nest into each other's empty corners.
  std::vector<std::vector<Vec2>> polys;
  for (int i = 0; i < 4; ++i)
    polys.push_back({{0, 0}, {600, 0}, {600, 100}, {100, 100}, {100, 600}, {0, 600}});
  auto outline = run_packer(kName, polygon_mesh(polys, 1024), json::object());
  auto rects = run_packer(kName, polygon_mesh(polys, 1024), {{"rect_min_fill", 0.0}});
  expect_valid_layout(*outline, 4);
  expect_valid_layout(*rects, 4);
  EXPECT_EQ(outline->report.at("tail_charts").get<int>(), 4);
  EXPECT_EQ(rects->report.at("tail_charts").get<int>(), 0);
  const double e_outline = layout_efficiency(*outline), e_rects = layout_efficiency(*rects);
  std::printf("4 L-shaped charts: efficiency %.3f by outline, %.3f as rectangles\n", e_outline, e_rects);
  EXPECT_GT(e_outline, 1.3 * e_rects);
}

TEST(PackersSquareTetris, TailOrdersKeepTheSmallestPacking) {
  // Sets of 40 right triangles and L-shapes of pseudo-random sizes (fixed seeds), all in the
  // outline tail. The tail is packed in decreasing padded box area, UV area and shorter side; the
  // smallest page wins. With order_trials_max_charts 0 only the box-area order runs; with fewer
  // tail charts allowed than there are, too. On these seeds another order wins at least once.
  auto area = [](const PackRun& r) {
    double s = 0;
    for (const auto& p : r.ctx.layout.pages) s += static_cast<double>(p.width) * p.height;
    return s;
  };
  int other_wins = 0, shuffle_wins = 0;
  for (uint32_t seed : {1u, 2u, 3u, 4u}) {
    std::vector<std::vector<Vec2>> polys;
    auto next = [&](int lo, int hi) {
      seed = seed * 1664525u + 1013904223u;
      return lo + static_cast<int>((seed >> 8) % static_cast<uint32_t>(hi - lo + 1));
    };
    for (int i = 0; i < 40; ++i) {
      const double x = 300.0 * (i % 8), y = 300.0 * (i / 8);
      const double a = next(20, 200), b = next(20, 200), t = next(5, 60);
      if (i % 2 == 0) polys.push_back({{x, y}, {x + a, y}, {x, y + b}});
      else polys.push_back({{x, y}, {x + a, y}, {x + a, y + t}, {x + t, y + t}, {x + t, y + b}, {x, y + b}});
    }
    // (width_refine_max_charts as order_trials_max_charts: no refinement or wide pages either)
    auto box_only =
        run_packer(kName, polygon_mesh(polys, 4096), {{"order_trials_max_charts", 0}, {"width_refine_max_charts", 0}});
    expect_valid_layout(*box_only, 4);
    EXPECT_EQ(box_only->report.at("tail_orders_tried").get<int>(), 1);
    EXPECT_EQ(box_only->report.at("tail_order").get<std::string>(), "box_area");
    const int tail = box_only->report.at("tail_charts").get<int>();
    EXPECT_GE(tail, 40);
    auto too_many = run_packer(kName, polygon_mesh(polys, 4096),
                               {{"order_trials_max_charts", tail - 1}, {"width_refine_max_charts", tail - 1}});
    EXPECT_EQ(too_many->report.at("tail_orders_tried").get<int>(), 1);
    EXPECT_EQ(area(*too_many), area(*box_only));
    auto all = run_packer(kName, polygon_mesh(polys, 4096), nlohmann::json::object());
    expect_valid_layout(*all, 4);
    EXPECT_EQ(all->report.at("tail_orders_tried").get<int>(), 3);
    const std::string won = all->report.at("tail_order").get<std::string>();
    std::printf("box-area order %.0f texels^2, kept %s %.0f\n", area(*box_only), won.c_str(), area(*all));
    EXPECT_LE(area(*all), area(*box_only));
    if (won != "box_area") {
      EXPECT_LT(area(*all), area(*box_only));
      ++other_wins;
    }
    // Shuffled orders: 6 more orders tried, never a larger page; the same orders on every run.
    auto shuffled = run_packer(kName, polygon_mesh(polys, 4096), {{"order_shuffles", 6}});
    expect_valid_layout(*shuffled, 4);
    EXPECT_EQ(shuffled->report.at("tail_orders_tried").get<int>(), 9);
    EXPECT_LE(area(*shuffled), area(*all));
    if (area(*shuffled) < area(*all)) ++shuffle_wins;
    auto again = run_packer(kName, polygon_mesh(polys, 4096), {{"order_shuffles", 6}});
    EXPECT_EQ(again->ctx.layout.wedge_uv, shuffled->ctx.layout.wedge_uv);
  }
  EXPECT_GE(other_wins, 1);
  std::printf("shuffled orders won on %d of 4 sets\n", shuffle_wins);
  EXPECT_GE(shuffle_wins, 1);
}

TEST(PackersSquareTetris, WidthRefineKeepsTheSmallestPackingAndStopsBeyondTheTailLimit) {
  // The tail sets of TailOrdersKeepTheSmallestPacking (other seeds): the widths around the best one
  // (width_refine steps of page_multiple) are packed too; the result is never larger than without
  // them, strictly smaller whenever the report says a refined width was kept, and the refinement
  // is off beyond width_refine_max_charts tail charts.
  auto area = [](const PackRun& r) {
    double s = 0;
    for (const auto& p : r.ctx.layout.pages) s += static_cast<double>(p.width) * p.height;
    return s;
  };
  int refined_wins = 0;
  for (uint32_t seed : {5u, 6u, 7u, 8u, 9u, 10u}) {
    std::vector<std::vector<Vec2>> polys;
    auto next = [&](int lo, int hi) {
      seed = seed * 1664525u + 1013904223u;
      return lo + static_cast<int>((seed >> 8) % static_cast<uint32_t>(hi - lo + 1));
    };
    for (int i = 0; i < 30; ++i) {
      const double x = 300.0 * (i % 8), y = 300.0 * (i / 8);
      const double a = next(20, 200), b = next(20, 200), t = next(5, 60);
      if (i % 2 == 0) polys.push_back({{x, y}, {x + a, y}, {x, y + b}});
      else polys.push_back({{x, y}, {x + a, y}, {x + a, y + t}, {x + t, y + t}, {x + t, y + b}, {x, y + b}});
    }
    // (wide_page_trials 0: the counts below are those of the width trials and the refinement)
    auto plain = run_packer(kName, polygon_mesh(polys, 4096), {{"width_refine", 0}, {"wide_page_trials", 0}});
    EXPECT_FALSE(plain->report.at("page_width_refined").get<bool>());
    auto refined = run_packer(kName, polygon_mesh(polys, 4096), {{"wide_page_trials", 0}});
    expect_valid_layout(*refined, 4);
    EXPECT_GT(refined->report.at("page_width_trials").get<int>(), plain->report.at("page_width_trials").get<int>());
    EXPECT_LE(area(*refined), area(*plain));
    if (refined->report.at("page_width_refined").get<bool>()) {
      EXPECT_LT(area(*refined), area(*plain));
      ++refined_wins;
    } else {
      EXPECT_EQ(refined->ctx.layout.wedge_uv, plain->ctx.layout.wedge_uv);
    }
    const int tail = plain->report.at("tail_charts").get<int>();
    auto beyond = run_packer(kName, polygon_mesh(polys, 4096),
                             {{"order_trials_max_charts", tail - 1}, {"width_refine_max_charts", tail - 1}, {"wide_page_trials", 0}});
    EXPECT_FALSE(beyond->report.at("page_width_refined").get<bool>());
    EXPECT_EQ(beyond->report.at("page_width_trials").get<int>(),
              plain->report.at("page_width_trials").get<int>() / plain->report.at("tail_orders_tried").get<int>());
  }
  std::printf("refined width kept on %d of 6 sets\n", refined_wins);
  EXPECT_GE(refined_wins, 1);
}

TEST(PackersSquareTetris, WidePageTrialsKeepAWidePageOnlyWhenSmaller) {
  // Three 100 x 90 rectangles, no quarter turns, gutter 2 (boxes 102 x 92: need 28152 texels^2),
  // pages rounded to 32, no refinement. The width trials sqrt(28152 / e), e = 1 .. 0.6, round to
  // 192 and 224: at 192 they stand in a column (102 x 276 -> page 128 x 288 = 36864), at 224 two
  // per row (204 x 184 -> 224 x 192). Wide pages: aspect 2 gives 288 (two per row again), aspect 4
  // gives 384 and 416, where the three lie in a row (306 x 92 -> page 320 x 96 = 30720).
  const std::vector<std::vector<Vec2>> polys = {{{0, 0}, {100, 0}, {100, 90}, {0, 90}},
                                                {{0, 100}, {100, 100}, {100, 190}, {0, 190}},
                                                {{0, 200}, {100, 200}, {100, 290}, {0, 290}}};
  auto with = [&](int wide) {
    return run_packer(kName, polygon_mesh(polys, 512),
                      {{"gutter", 2}, {"page_multiple", 32}, {"allow_rotation", false}, {"width_refine", 0},
                       {"block_grid", 0}, {"wide_page_trials", wide}});
  };
  auto off = with(0), two = with(1), four = with(2);
  EXPECT_EQ(off->report.at("page_sizes"), json::parse("[[128, 288]]"));
  EXPECT_FALSE(off->report.at("page_width_wide").get<bool>());
  EXPECT_EQ(two->report.at("page_sizes"), json::parse("[[128, 288]]"));  // tried, not smaller: not kept
  EXPECT_FALSE(two->report.at("page_width_wide").get<bool>());
  EXPECT_EQ(two->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  EXPECT_GT(two->report.at("page_width_trials").get<int>(), off->report.at("page_width_trials").get<int>());
  EXPECT_EQ(four->report.at("page_sizes"), json::parse("[[320, 96]]"));
  EXPECT_TRUE(four->report.at("page_width_wide").get<bool>());
  expect_valid_layout(*four, 2);
  // the wide pages run with at most width_refine_max_charts tail charts (3 here), whatever
  // order_trials_max_charts allows (the tail orders)
  auto beyond = run_packer(kName, polygon_mesh(polys, 512),
                           {{"gutter", 2}, {"page_multiple", 32}, {"allow_rotation", false}, {"width_refine", 0},
                            {"block_grid", 0}, {"width_refine_max_charts", 2}});
  EXPECT_EQ(beyond->report.at("page_sizes"), json::parse("[[128, 288]]"));
  auto one_order = run_packer(kName, polygon_mesh(polys, 512),
                              {{"gutter", 2}, {"page_multiple", 32}, {"allow_rotation", false}, {"width_refine", 0},
                               {"block_grid", 0}, {"order_trials_max_charts", 2}});
  EXPECT_EQ(one_order->report.at("page_sizes"), json::parse("[[320, 96]]"));
  EXPECT_EQ(one_order->report.at("tail_orders_tried").get<int>(), 1);
}

namespace {
/// Lowest output UV corner of each polygon's chart (polygon i = faces 2i and 2i + 1: quads only).
std::vector<Vec2> quad_corners(const PackRun& run, size_t quads) {
  std::vector<Vec2> lo(quads, Vec2(1e9, 1e9));
  for (size_t f = 0; f < 2 * quads; ++f)
    for (int w : run.ctx.atlas.face_wedge[f]) lo[f / 2] = lo[f / 2].cwiseMin(run.ctx.layout.wedge_uv[static_cast<size_t>(w)]);
  return lo;
}
}  // namespace

TEST(PackersSquareTetris, OutlineTailLowestThenLeftmostAroundNarrowGaps) {
  // Every chart in the outline tail, no turns, one page width, gutter 4 (masks grown by 2 below and
  // left, 2 above and right). Page width 64: C's padded 64 cells. Area order: C (64 x 14 padded),
  // A and B (29 x 24, or 30 x 24), then the 5 x 5 padded single cell D.
  // - C: (0, 0) -> box corner (2, 2). A: (0, 14) -> (2, 16). B: (29, 14) -> (31, 16) [or (30, 14)].
  // - Rows 14..37 keep cells [58, 64) free (6 cells) beside B: D's 5-cell mask rests there at
  //   (58, 14) -> (60, 16). With A, B one cell wider the gap is [60, 64), 4 cells, too narrow for
  //   any mask (the page's search keeps no free run shorter than its shortest mask run): D goes
  //   above them, at (0, 38) -> (2, 40).
  const json opts = {{"width_trials", 1}, {"tail_side", 4096}, {"allow_rotation", false},
                     {"order_trials_max_charts", 0}, {"gutter", 4}, {"page_multiple", 32}};
  for (const int ab : {25, 26}) {
    const std::vector<std::vector<Vec2>> polys = {
        {{0, 0}, {60, 0}, {60, 10}, {0, 10}},                                                     // C
        {{0, 0}, {double(ab), 0}, {double(ab), 20}, {0, 20}},                                     // A
        {{100, 100}, {100.0 + ab, 100}, {100.0 + ab, 120}, {100, 120}},                           // B
        {{300.25, 300.25}, {300.75, 300.25}, {300.75, 300.75}, {300.25, 300.75}},                 // D: one cell
    };
    auto run = run_packer(kName, polygon_mesh(polys, 1024), opts);
    expect_valid_layout(*run, 4);
    EXPECT_EQ(run->report.at("page_sizes"), json::parse("[[64, 64]]"));
    const std::vector<Vec2> lo = quad_corners(*run, 4);
    EXPECT_EQ(lo[0], Vec2(2, 2));
    EXPECT_EQ(lo[1], Vec2(2, 16));
    EXPECT_EQ(lo[2], Vec2(ab == 25 ? 31 : 32, 16));
    EXPECT_EQ(lo[3], ab == 25 ? Vec2(60.25, 16.25) : Vec2(2.25, 40.25)) << "A and B " << ab << " cells wide";
  }
}

TEST(PackersSquareTetris, OutlineTailTakesTheTurnWithTheLowestTopThenTheLowerTurn) {
  // Every chart in the outline tail, one page width (64), gutter 4, quarter turns allowed; area
  // order C (64 x 14 padded), L (14 x 44 padded upright), the triangle T (14 x 14 padded).
  // - C lies flat at (0, 0) (turn 0 top 14; turn 1 would be 64).
  // - L upright would top at 14 + 44 = 58, turned a quarter (44 x 14) at 14 + 14 = 28: turned, at
  //   (0, 14) -> box corner (2, 16).
  // - T's four turns (different cells, same 14 x 14 box) all fit at (44, 14) with top 28: the tie
  //   goes to the lower turn, 0 (not turned), box corner (46, 16).
  const json opts = {{"width_trials", 1}, {"tail_side", 4096}, {"order_trials_max_charts", 0},
                     {"gutter", 4}, {"page_multiple", 32}, {"block_grid", 0}};
  const std::vector<std::vector<Vec2>> polys = {
      {{0, 0}, {60, 0}, {60, 10}, {0, 10}},          // C: faces 0, 1
      {{100, 100}, {110, 100}, {110, 140}, {100, 140}},  // L: faces 2, 3
      {{300, 300}, {310, 300}, {300, 310}},           // T: face 4
  };
  auto run = run_packer(kName, polygon_mesh(polys, 1024), opts);
  expect_valid_layout(*run, 4);
  ASSERT_EQ(run->report.at("page_sizes"), json::parse("[[64, 32]]"));
  EXPECT_EQ(run->report.at("charts_turned_90"), 1);
  auto corner = [&](size_t f0, size_t f1) {  // lowest output UV corner of faces [f0, f1)
    Vec2 lo(1e9, 1e9);
    for (size_t f = f0; f < f1; ++f)
      for (int w : run->ctx.atlas.face_wedge[f]) lo = lo.cwiseMin(run->ctx.layout.wedge_uv[static_cast<size_t>(w)]);
    return lo;
  };
  EXPECT_EQ(corner(0, 2), Vec2(2, 2));
  EXPECT_EQ(corner(2, 4), Vec2(2, 16));
  EXPECT_EQ(corner(4, 5), Vec2(46, 16));
  // T not turned: its right angle stays at its lowest-left corner.
  const Vec2 right_angle = run->ctx.layout.wedge_uv[static_cast<size_t>(run->ctx.atlas.face_wedge[4][0])];
  EXPECT_EQ(right_angle, Vec2(46, 16));
}

namespace {
/// Per chart with faces: whether its output UVs are its input texels turned by k quarter turns and
/// moved by T with T on the g x g block grid, both measured in image coordinates (x, page height -
/// y: JPEG's blocks start at the image's top-left corner), so that the input's g x g blocks land on
/// output blocks. Checked independently of the packer's residues (any k, T found from the UVs).
std::vector<bool> charts_on_block_grid(const PackRun& run, int g) {
  const Atlas& a = run.ctx.atlas;
  const Layout& L = run.ctx.layout;
  const auto faces = a.chart_faces();
  std::vector<bool> out;
  for (int c = 0; c < a.num_charts; ++c) {
    const auto& fs = faces[static_cast<size_t>(c)];
    if (fs.empty()) continue;
    const double h_out = L.pages[static_cast<size_t>(L.chart_page[static_cast<size_t>(c)])].height;
    auto in_img = [&](int f, int k) {
      const Vec2 t = run.mesh.corner_texel(static_cast<size_t>(f), k);
      return Vec2(t.x(), run.mesh.pages[0].height - t.y());
    };
    auto out_img = [&](int f, int k) {
      const Vec2 t = L.wedge_uv[static_cast<size_t>(a.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
      return Vec2(t.x(), h_out - t.y());
    };
    bool on = false;
    for (int q = 0; q < 4 && !on; ++q) {
      const Vec2 T = out_img(fs[0], 0) - packing::rotate90(in_img(fs[0], 0), q);
      bool rigid = true;
      for (int f : fs)
        for (int k = 0; k < 3; ++k)
          rigid = rigid && (out_img(f, k) - packing::rotate90(in_img(f, k), q) - T).cwiseAbs().maxCoeff() < 1e-6;
      const auto on_grid = [g](double v) {
        const double r = std::fmod(std::fmod(v, g) + g, g);
        return std::min(r, g - r) < 1e-6;
      };
      on = rigid && on_grid(T.x()) && on_grid(T.y());
    }
    out.push_back(on);
  }
  return out;
}
}  // namespace

TEST(PackersSquareTetris, BlockGridPutsExactChartsOnTheInputBlockGrid) {
  // Input page 1003 texels high (not a multiple of 8: the input's block rows start at its top, so
  // y residues differ from x's), random charts with fractional corners and rotated rectangles;
  // tail_side 40 makes the larger ones rectangles (holes and horizon) and the rest the outline
  // tail. With block_grid 8 every chart's input 8 x 8 blocks must land on output blocks; without
  // it most do not (the check can fail).
  std::mt19937 rng(5);
  auto polys = random_polygons(rng, 160, 3, 70, 1003);
  for (size_t i = 0; i < polys.size(); i += 3)
    for (Vec2& p : polys[i]) p += Vec2(0.37, 0.61);  // off the texel grid: fractional anchors
  const json opts = {{"tail_side", 40}, {"width_trials", 3}, {"block_grid", 0}};
  json grid = opts;
  grid["block_grid"] = 8;
  grid["block_grid_max_cost"] = 1.0;  // keep the aligned packing whatever its area
  for (int gutter : {2, 4}) {
    SCOPED_TRACE("gutter " + std::to_string(gutter));
    json o = grid;
    o["gutter"] = gutter;
    auto run = run_packer(kName, polygon_mesh(polys, 1003), o);
    expect_valid_layout(*run, gutter);
    EXPECT_EQ(exact_chart_fraction(*run), 1.0);
    const auto on = charts_on_block_grid(*run, 8);
    EXPECT_EQ(std::count(on.begin(), on.end(), true), static_cast<long>(on.size()));
    EXPECT_GT(run->report.at("outline_drops").get<int>(), 0);
    EXPECT_LT(run->report.at("tail_charts").get<size_t>(), on.size());  // some rectangles too
    EXPECT_TRUE(run->report.at("block_grid_kept").get<bool>());
  }
  auto off = run_packer(kName, polygon_mesh(polys, 1003), opts);
  const auto on = charts_on_block_grid(*off, 8);
  EXPECT_LT(std::count(on.begin(), on.end(), true), static_cast<long>(on.size()) / 2);
}

TEST(PackersSquareTetris, BlockGridTrialKeepsTheSmallerPackingAndNeedsWholeBlocks) {
  // Default options (block_grid 8, max cost 0): the aligned packing, at the other packing's tail
  // order and page width, is kept only when it needs no more page area than the other; never a
  // larger page than without the grid. Page sides that are not whole blocks (page_multiple 12) give
  // no trial.
  std::mt19937 rng(9);
  const auto polys = random_polygons(rng, 120, 3, 50, 1024);
  auto area = [](const PackRun& r) {
    double s = 0;
    for (const auto& p : r.ctx.layout.pages) s += static_cast<double>(p.width) * p.height;
    return s;
  };
  auto off = run_packer(kName, polygon_mesh(polys, 1024), {{"block_grid", 0}});
  auto trial = run_packer(kName, polygon_mesh(polys, 1024));
  expect_valid_layout(*trial, 4);
  EXPECT_LE(area(*trial), area(*off));
  const auto on = charts_on_block_grid(*trial, 8);
  const long aligned = std::count(on.begin(), on.end(), true);
  EXPECT_EQ(trial->report.at("block_grid_kept").get<bool>(), aligned == static_cast<long>(on.size()));
  // The trial packs one page width in one tail order: the other packing's (its cost was a whole
  // second packing over every order and width before 2026-12-03).
  EXPECT_GT(off->report.at("page_width_trials").get<int>(), 1);
  EXPECT_EQ(trial->report.at("block_grid_width_trials").get<int>(), 1);
  auto odd = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 12}, {"block_grid_max_cost", 1.0}});
  expect_valid_layout(*odd, 4);
  EXPECT_FALSE(odd->report.at("block_grid_kept").get<bool>());
}

TEST(PackersSquareTetris, BlockGridTrialPackedBesideForAnotherWidthIsPackedAgain) {
  // 64 squares of 30 x 30 texels (gutter 4, padded 34): of the page widths tried (288, 320, 352),
  // 288 packs them 8 x 8 on the smallest page, so the first width trial wins. That trial runs on
  // the calling thread, the only one reporting progress; a pause in its first report (not a
  // measured time: it only lets the other threads go first) makes the other widths finish first,
  // so the block-grid trial packed beside them is packed for one of those. Kept whatever its area
  // (block_grid_max_cost 1), it must be packed again for width 288: every placement must be that
  // of one thread (where it runs after every width trial).
  std::vector<std::vector<Vec2>> squares;
  for (int i = 0; i < 64; ++i) {
    const Vec2 o(40.0 * (i % 16), 40.0 * (i / 16));
    squares.push_back({o, o + Vec2(30, 0), o + Vec2(30, 30), o + Vec2(0, 30)});
  }
  auto pause_first_report = [] {
    auto first = std::make_shared<bool>(true);
    return ProgressFn([first](const std::string&, double) {
      if (*first) std::this_thread::sleep_for(std::chrono::milliseconds(200));
      *first = false;
      return true;
    });
  };
  const json opts = {{"block_grid_max_cost", 1.0}, {"order_trials_max_charts", 0}};
  std::vector<std::unique_ptr<PackRun>> runs;
  for (int threads : {1, 2, 4}) {
    set_thread_count(threads);
    runs.push_back(run_packer(kName, polygon_mesh(squares, 1024), opts, nullptr, pause_first_report()));
  }
  set_thread_count(0);
  expect_valid_layout(*runs[0], 4);
  EXPECT_TRUE(runs[0]->report.at("block_grid_kept").get<bool>());
  EXPECT_EQ(runs[0]->ctx.layout.pages[0].width, 288);
  for (size_t k = 1; k < runs.size(); ++k) {
    EXPECT_EQ(runs[k]->report.at("page_sizes"), runs[0]->report.at("page_sizes"));
    EXPECT_EQ(runs[k]->ctx.layout.wedge_uv, runs[0]->ctx.layout.wedge_uv);
  }
}

TEST(PackersSquareTetris, FreeTrialFreesAPartlyExactChartWhenThatSavesPageArea) {
  // Chart 0: a 400 x 12 strip at 45 degrees (two triangles). A "merger" moved its corner 1 by a
  // quarter texel: triangle (0, 1, 2) is no longer grid-exact, triangle (0, 2, 3) is (half the
  // area: exact under exact_fraction 0.25, so only quarter turns: a ~292 x 292 box). Freed
  // (exact_fraction 1), it turns to its 400 x 12 rectangle: far less page area, so the free trial
  // keeps that packing; with free_trial_gain 1 (off) the chart stays exact.
  const double c = std::sqrt(0.5);
  const Vec2 o(500.3, 400.7), d(c, c), n(-c, c);
  const std::vector<std::vector<Vec2>> polys = {{o, o + 400 * d, o + 400 * d + 12 * n, o + 12 * n},
                                                {{50, 50}, {80, 50}, {80, 80}, {50, 80}},
                                                {{100, 50}, {120, 50}, {120, 90}, {100, 90}}};
  auto edit = [](Atlas& a) {
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] == 0) {
        a.wedge_uv[static_cast<size_t>(a.face_wedge[f][1])] += Vec2(0.25, -0.1);  // corner 1 of the first triangle
        break;
      }
  };
  auto freed = run_packer(kName, polygon_mesh(polys, 1024), json::object(), edit);
  expect_valid_layout(*freed, 4);
  EXPECT_TRUE(freed->report.at("free_trial_kept").get<bool>());
  EXPECT_EQ(freed->report.at("charts_rotated_free").get<int>(), 1);
  auto kept = run_packer(kName, polygon_mesh(polys, 1024), {{"free_trial_gain", 1.0}}, edit);
  expect_valid_layout(*kept, 4);
  EXPECT_FALSE(kept->report.at("free_trial_kept").get<bool>());
  EXPECT_EQ(kept->report.at("charts_exact").get<int>(), 3);
  const auto mp = [](const PackRun& r) { return r.report.at("page_megapixels").get<double>(); };
  EXPECT_LT(mp(*freed), 0.5 * mp(*kept));
  // Fully exact charts (nothing partly resampled): no trial.
  auto plain = run_packer(kName, polygon_mesh(polys, 1024));
  EXPECT_FALSE(plain->report.at("free_trial_kept").get<bool>());
  EXPECT_EQ(plain->report.at("charts_exact").get<int>(), 3);
}

namespace {

/// A V of two arms (length len, width t) from the apex at the origin, along 0 and `deg` degrees,
/// counter-clockwise, star-shaped from the apex (fan-triangulated into 4 triangles).
std::vector<Vec2> v_polygon(double len, double t, double deg, const Vec2& at) {
  const double a = deg * 3.14159265358979323846 / 180;
  const Vec2 d(std::cos(a), std::sin(a)), n(std::sin(a), -std::cos(a));  // arm 2 and its inner normal
  // inner corner: y = t on arm 1's inner side, distance t from arm 2's axis on its inner side
  const double x = (t + t * std::cos(a)) / std::sin(a);
  return {at, at + Vec2(len, 0), at + Vec2(len, t), at + Vec2(x, t), at + len * d + t * n, at + len * d};
}

/// Chart 0: a narrow V (two 200 x 10 arms 20 degrees apart, 4 triangles); chart 1: a right
/// triangle with 140-texel legs (the angle-search tests' atlas).
std::vector<std::vector<Vec2>> v_and_triangle() {
  return {v_polygon(200, 10, 20, {300, 300}), {{10, 10}, {150, 10}, {10, 150}}};
}

/// Rotates chart 0's atlas UVs by `angle` radians about (0, 0) (a merger's output: chart 0 free).
std::function<void(Atlas&)> turn_chart0(double angle) {
  return [angle](Atlas& a) {
    std::vector<uint8_t> done(a.wedge_uv.size(), 0);
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] == 0)
        for (int w : a.face_wedge[f])
          if (!done[static_cast<size_t>(w)]++) a.wedge_uv[static_cast<size_t>(w)] = packing::rotate(a.wedge_uv[static_cast<size_t>(w)], angle);
  };
}

}  // namespace

/// The turn (radians, in (-pi, pi]) that takes chart `chart`'s atlas UVs to its output UVs, from
/// each of its faces' first edge; every face must give the same turn (one rotation per chart).
double chart_turn(const PackRun& run, int chart) {
  const Atlas& a = run.ctx.atlas;
  double turn = 0;
  bool first = true;
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    if (a.face_chart[f] != chart) continue;
    const int w0 = a.face_wedge[f][0], w1 = a.face_wedge[f][1];
    const Vec2 in = a.wedge_uv[static_cast<size_t>(w1)] - a.wedge_uv[static_cast<size_t>(w0)];
    const Vec2 out = run.ctx.layout.wedge_uv[static_cast<size_t>(w1)] - run.ctx.layout.wedge_uv[static_cast<size_t>(w0)];
    const double t = std::atan2(in.x() * out.y() - in.y() * out.x(), in.dot(out));
    if (!first) {
      EXPECT_NEAR(std::remainder(t - turn, 2 * 3.14159265358979323846), 0.0, 1e-9) << "face " << f;
    }
    turn = first ? t : turn;
    first = false;
  }
  return turn;
}

TEST(PackersSquareTetris, AngleSearchFindsTheAngleAConcaveChartPacksBestAt) {
  // Chart 0: a narrow V (two 200 x 10 arms 20 degrees apart, 4 triangles), turned by 0.3 rad by a
  // "merger", so free; chart 1: a right triangle with 140-texel legs (exact). At the V's
  // minimum-area angle (one arm along the rectangle) the page is 216 x 144 texels (page_multiple
  // 4); the search tries that angle plus j * 7.5 degrees and finds a smaller page (200 x 144 when
  // written). Every chart's output is its atlas UVs turned (no reflection) and moved, no overlaps.
  const std::vector<std::vector<Vec2>> polys = v_and_triangle();
  const json opts = {{"page_multiple", 4}};
  json off_opts = opts;
  off_opts["angle_search_max_charts"] = 0;
  auto on = run_packer(kName, polygon_mesh(polys, 1024), opts, turn_chart0(0.3));
  auto off = run_packer(kName, polygon_mesh(polys, 1024), off_opts, turn_chart0(0.3));
  expect_valid_layout(*on, 4);
  expect_valid_layout(*off, 4);
  const auto mp = [](const PackRun& r) { return r.report.at("page_megapixels").get<double>(); };
  EXPECT_LT(mp(*on), mp(*off));
  EXPECT_EQ(on->report.at("angle_search_charts_turned").get<int>(), 1);
  EXPECT_EQ(on->report.at("angle_search_packings").get<int>(), 11);  // 12 angles, the first packed already
  EXPECT_DOUBLE_EQ(on->report.at("angle_search_megapixels_before").get<double>(), mp(*off));
  EXPECT_EQ(off->report.at("angle_search_packings").get<int>(), 0);
  // The V's turn differs from the minimum-area one by a multiple of 7.5 degrees (modulo quarter
  // turns), not by a multiple of 90; the exact triangle turns by quarter turns only.
  const double step = 7.5 * 3.14159265358979323846 / 180;
  const double extra = std::remainder(chart_turn(*on, 0) - chart_turn(*off, 0), step);
  EXPECT_NEAR(extra, 0.0, 1e-9);
  EXPECT_GT(std::abs(std::remainder(chart_turn(*on, 0) - chart_turn(*off, 0), 3.14159265358979323846 / 2)), 1e-3);
  EXPECT_NEAR(std::remainder(chart_turn(*on, 1), 3.14159265358979323846 / 2), 0.0, 1e-12);
  // Same layout with 1 and 2 threads (the width trials of each packing run side by side).
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    auto t = run_packer(kName, polygon_mesh(polys, 1024), opts, turn_chart0(0.3));
    EXPECT_EQ(t->ctx.layout.wedge_uv, on->ctx.layout.wedge_uv) << threads << " threads";
    EXPECT_EQ(t->report.at("page_sizes"), on->report.at("page_sizes"));
  }
  set_thread_count(0);
  // The limit: 2 charts, at most 1 allowed: no search.
  auto limited = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_charts", 1}},
                            turn_chart0(0.3));
  EXPECT_EQ(limited->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_EQ(limited->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  // Free rotation off: no search either (free charts keep their atlas angle).
  auto fixed = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"free_rotation", false}}, turn_chart0(0.3));
  EXPECT_EQ(fixed->report.at("angle_search_packings").get<int>(), 0);
}

TEST(PackersSquareTetris, AngleSearchStopsAtItsWorkCap) {
  // The V and the triangle of the test above: without the search the page is 216 x 144 texels
  // (0.031104 MP), so the V's 11 candidates are 11 x 0.031104 = 0.342144 MP of work. A cap of
  // 0.34 MP skips them (the layout without the search, reported as capped); 0.35 lets them run.
  const std::vector<std::vector<Vec2>> polys = v_and_triangle();
  auto off = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_charts", 0}},
                        turn_chart0(0.3));
  ASSERT_DOUBLE_EQ(off->report.at("page_megapixels").get<double>(), 216.0 * 144.0 / 1e6);
  EXPECT_FALSE(off->report.at("angle_search_capped").get<bool>());
  auto capped = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_work", 0.34}},
                           turn_chart0(0.3));
  EXPECT_TRUE(capped->report.at("angle_search_capped").get<bool>());
  EXPECT_EQ(capped->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_DOUBLE_EQ(capped->report.at("angle_search_work_megapixels").get<double>(), 0.0);
  EXPECT_EQ(capped->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  auto ran = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_work", 0.35}},
                        turn_chart0(0.3));
  EXPECT_FALSE(ran->report.at("angle_search_capped").get<bool>());
  EXPECT_EQ(ran->report.at("angle_search_packings").get<int>(), 11);
  EXPECT_NEAR(ran->report.at("angle_search_work_megapixels").get<double>(), 11 * 216.0 * 144.0 / 1e6, 1e-12);
  EXPECT_LT(ran->report.at("page_megapixels").get<double>(), off->report.at("page_megapixels").get<double>());
}

TEST(PackersSquareTetris, AngleSearchNeverGivesALargerPage) {
  // A free 200 x 40 rectangle (turned by 0.3 rad) and a 20 x 20 square: every other angle gives
  // the rectangle a larger box, so the search keeps the minimum-area angle (the same layout).
  const std::vector<std::vector<Vec2>> rect = {{{100, 100}, {300, 100}, {300, 140}, {100, 140}},
                                               {{400, 400}, {420, 400}, {420, 420}, {400, 420}}};
  auto on = run_packer(kName, polygon_mesh(rect, 1024), json::object(), turn_chart0(0.3));
  auto off = run_packer(kName, polygon_mesh(rect, 1024), {{"angle_search_max_charts", 0}}, turn_chart0(0.3));
  expect_valid_layout(*on, 4);
  EXPECT_EQ(on->report.at("angle_search_packings").get<int>(), 11);
  EXPECT_EQ(on->report.at("angle_search_charts_turned").get<int>(), 0);
  EXPECT_EQ(on->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  // V's of several openings and widths with a bar, a square or a triangle (angle step 15 degrees):
  // never a larger page than without the search, smaller on some.
  int smaller = 0;
  for (double deg : {30.0, 60.0, 70.0})
    for (int other = 0; other < 3; ++other) {
      std::vector<std::vector<Vec2>> polys = {v_polygon(200, 10, deg, {300, 300})};
      if (other == 0) polys.push_back({{10, 10}, {190, 10}, {190, 40}, {10, 40}});
      if (other == 1) polys.push_back({{10, 10}, {90, 10}, {90, 90}, {10, 90}});
      if (other == 2) polys.push_back({{10, 10}, {150, 10}, {10, 150}});
      const json o = {{"page_multiple", 4}, {"angle_step_degrees", 15}};
      json o_off = o;
      o_off["angle_search_max_charts"] = 0;
      auto a = run_packer(kName, polygon_mesh(polys, 1024), o, turn_chart0(0.3));
      auto b = run_packer(kName, polygon_mesh(polys, 1024), o_off, turn_chart0(0.3));
      expect_valid_layout(*a, 4);
      EXPECT_EQ(a->report.at("angle_search_packings").get<int>(), 5);
      const double ma = a->report.at("page_megapixels").get<double>(), mb = b->report.at("page_megapixels").get<double>();
      EXPECT_LE(ma, mb) << deg << " degrees, chart " << other;
      smaller += ma < mb ? 1 : 0;
    }
  EXPECT_GE(smaller, 1);
}

TEST(PackersSquareTetris, AngleSearchRunsInTheFreeTrial) {
  // Chart 0: a V (two 200 x 10 arms 30 degrees apart, 4 triangles) turned by 0.3 rad in the input,
  // of which a "merger" moved one corner of the first triangle by a quarter texel: 3 triangles stay
  // grid-exact, so it is exact (quarter turns only) and partly resampled. Chart 1: an exact right
  // triangle with 140-texel legs. The free trial frees the V; at its minimum-area angle that saves
  // less than free_trial_gain, so without the search the exact packing stays; with the search the
  // free trial's V is turned further and its packing saves enough to be kept.
  std::vector<Vec2> v = v_polygon(200, 10, 30, {0, 0});
  for (Vec2& p : v) p = packing::rotate(p, 0.3) + Vec2(400.3, 300.7);
  const std::vector<std::vector<Vec2>> polys = {v, {{10, 10}, {150, 10}, {10, 150}}};
  auto edit = [](Atlas& a) {
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] == 0) {
        a.wedge_uv[static_cast<size_t>(a.face_wedge[f][1])] += Vec2(0.25, -0.1);  // corner 1 of the first triangle
        break;
      }
  };
  auto on = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}}, edit);
  auto off = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_charts", 0}}, edit);
  expect_valid_layout(*on, 4);
  expect_valid_layout(*off, 4);
  EXPECT_FALSE(off->report.at("free_trial_kept").get<bool>());
  EXPECT_EQ(off->report.at("charts_exact").get<int>(), 2);
  EXPECT_TRUE(on->report.at("free_trial_kept").get<bool>());
  EXPECT_EQ(on->report.at("charts_exact").get<int>(), 1);
  EXPECT_EQ(on->report.at("angle_search_charts_turned").get<int>(), 1);
  EXPECT_EQ(on->report.at("angle_search_packings").get<int>(), 11);  // the free trial's V only
  const auto mp = [](const PackRun& r) { return r.report.at("page_megapixels").get<double>(); };
  EXPECT_LT(mp(*on), mp(*off));
  EXPECT_DOUBLE_EQ(on->report.at("angle_search_megapixels_before").get<double>(), mp(*off));
  EXPECT_GT(std::abs(std::remainder(chart_turn(*on, 0), 3.14159265358979323846 / 2)), 1e-3);  // not a quarter turn
}

TEST(PackersSquareTetris, TheAngleSearchNeverEndsLargerThanWithoutItWhenTheFreeTrialApplies) {
  // A free V (turned by `turn` in the input), a partly exact 400 x 12 strip at 45 degrees (freed by
  // the free trial: a far smaller box) and an exact triangle, at 24 input turns of the V: with the
  // search on, the page is never larger than with it off, and the free trial is kept whenever it is
  // kept without the search. (A free trial built on the searched charts once ended larger: 0.2458
  // against 0.2396 MP on a held-out OSGB level read from an OBJ conversion, with the search on its 55
  // charts; these small meshes do not reproduce that case, they pin the invariant.)
  const double c = std::sqrt(0.5);
  const Vec2 o(600.3, 400.7), d(c, c), n(-c, c);
  auto edit = [](Atlas& a) {
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] == 1) {
        a.wedge_uv[static_cast<size_t>(a.face_wedge[f][1])] += Vec2(0.25, -0.1);  // the strip's first triangle
        break;
      }
  };
  const auto mp = [](const PackRun& r) { return r.report.at("page_megapixels").get<double>(); };
  int smaller = 0;
  for (int k = 0; k < 24; ++k) {
    std::vector<Vec2> v = v_polygon(200, 10, 25, {0, 0});
    for (Vec2& p : v) p = packing::rotate(p, 0.13 * k) + Vec2(300.3, 300.7);
    const std::vector<std::vector<Vec2>> polys = {
        v, {o, o + 400 * d, o + 400 * d + 12 * n, o + 12 * n}, {{10, 10}, {150, 10}, {10, 150}}};
    auto on = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}}, edit);
    auto off = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}, {"angle_search_max_charts", 0}}, edit);
    expect_valid_layout(*on, 4);
    EXPECT_LE(mp(*on), mp(*off)) << "turn " << k;
    EXPECT_DOUBLE_EQ(on->report.at("angle_search_megapixels_before").get<double>(), mp(*off)) << "turn " << k;
    if (off->report.at("free_trial_kept").get<bool>() && mp(*on) == mp(*off)) {
      EXPECT_TRUE(on->report.at("free_trial_kept").get<bool>()) << "turn " << k;
    }
    smaller += mp(*on) < mp(*off) ? 1 : 0;
  }
  EXPECT_GE(smaller, 1);
}

TEST(PackersSquareTetris, AngleSearchSkipsTheWidthTrialsBoundToStopAsBefore) {
  // Two exact right triangles (legs 300 and 240 texels) and a small free V (two 60 x 6 arms 30
  // degrees apart, turned by 0.3 rad by a "merger"): the V comes last in every tail order. A width
  // trial of the packing whose page needed the kept page's area before the V was placed stops the
  // same way when only the V is turned (same triangles, same width), so the search skips it; the
  // other trials take the triangles' placements from the kept packing's trial of the same order and
  // width (replayed: every chart is in the outline tail) and search the V's only. The result is the
  // one of packing every candidate's trials in full.
  const std::vector<std::vector<Vec2>> polys = {
      v_polygon(60, 6, 30, {700, 700}), {{10, 10}, {310, 10}, {10, 310}}, {{400, 10}, {640, 10}, {400, 250}}};
  const json opts = {{"page_multiple", 4}, {"width_trials", 8}};
  auto on = run_packer(kName, polygon_mesh(polys, 1024), opts, turn_chart0(0.3));
  expect_valid_layout(*on, 4);
  const int trials = on->report.at("angle_search_width_trials").get<int>();
  const int skipped = on->report.at("angle_search_width_trials_skipped").get<int>();
  EXPECT_EQ(on->report.at("angle_search_packings").get<int>(), 11);
  const int replayed = on->report.at("angle_search_placements_replayed").get<int>();
  EXPECT_GT(skipped, 0);
  EXPECT_LT(skipped, trials);
  EXPECT_GT(replayed, 0);
  EXPECT_LE(replayed, 2 * (trials - skipped));  // at most the two triangles per trial packed
  json off_opts = opts;
  off_opts["angle_search_max_charts"] = 0;
  auto off = run_packer(kName, polygon_mesh(polys, 1024), off_opts, turn_chart0(0.3));
  EXPECT_LE(on->report.at("page_megapixels").get<double>(), off->report.at("page_megapixels").get<double>());
  EXPECT_EQ(off->report.at("angle_search_width_trials").get<int>(), 0);
  // Same layout and counts with 1 and 2 threads (candidates and width trials side by side).
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    auto t = run_packer(kName, polygon_mesh(polys, 1024), opts, turn_chart0(0.3));
    EXPECT_EQ(t->ctx.layout.wedge_uv, on->ctx.layout.wedge_uv) << threads << " threads";
    EXPECT_EQ(t->report.at("angle_search_width_trials_skipped").get<int>(), skipped) << threads << " threads";
    EXPECT_EQ(t->report.at("angle_search_placements_replayed").get<int>(), replayed) << threads << " threads";
  }
  set_thread_count(0);
}

TEST(PackersSquareTetris, AngleSearchOpensBelowAPackingFactor) {
  // The V and the triangle of AngleSearchFindsTheAngleAConcaveChartPacksBestAt with
  // angle_search_max_charts 1 (2 charts: no search by count). Without the search the page is 216 x
  // 144 texels (0.031104 MP), which the charts' dilated outlines fill far less than entirely.
  // angle_search_packing_below 1 opens the search (any packing factor is below 1): the V's 11
  // candidates run and the page is smaller, as with the search on by count; 0.01 (no packing is that
  // sparse) and 0 (off, the default) do not. An opened search has its own work cap:
  // angle_search_opened_max_work 0.34 MP skips the V's 11 x 0.031104 MP of candidates.
  const std::vector<std::vector<Vec2>> polys = v_and_triangle();
  const json base = {{"page_multiple", 4}, {"angle_search_max_charts", 1}};
  auto with = [&](const json& extra) {
    json o = base;
    for (const auto& [k, v] : extra.items()) o[k] = v;
    return run_packer(kName, polygon_mesh(polys, 1024), o, turn_chart0(0.3));
  };
  const auto mp = [](const PackRun& r) { return r.report.at("page_megapixels").get<double>(); };
  auto off = with(json::object());
  ASSERT_DOUBLE_EQ(mp(*off), 216.0 * 144.0 / 1e6);
  EXPECT_EQ(off->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_FALSE(off->report.at("angle_search_opened").get<bool>());
  auto opened = with({{"angle_search_packing_below", 1.0}});
  expect_valid_layout(*opened, 4);
  EXPECT_TRUE(opened->report.at("angle_search_opened").get<bool>());
  EXPECT_EQ(opened->report.at("angle_search_packings").get<int>(), 11);
  EXPECT_LT(mp(*opened), mp(*off));
  auto by_count = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}}, turn_chart0(0.3));
  EXPECT_EQ(opened->ctx.layout.wedge_uv, by_count->ctx.layout.wedge_uv);
  EXPECT_FALSE(by_count->report.at("angle_search_opened").get<bool>());
  auto dense = with({{"angle_search_packing_below", 0.01}});
  EXPECT_EQ(dense->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_EQ(dense->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  auto capped = with({{"angle_search_packing_below", 1.0}, {"angle_search_opened_max_work", 0.34}});
  EXPECT_TRUE(capped->report.at("angle_search_capped").get<bool>());
  EXPECT_EQ(capped->report.at("angle_search_packings").get<int>(), 0);
  auto uncapped = with({{"angle_search_packing_below", 1.0}, {"angle_search_opened_max_work", 0.35}});
  EXPECT_EQ(uncapped->report.at("angle_search_packings").get<int>(), 11);
}

TEST(PackersSquareTetris, AngleSearchOpensOnChartsWithALargeBox) {
  // The V and the triangle of AngleSearchOpensBelowAPackingFactor (angle_search_max_charts 1: no
  // search by count; page 216 x 144 without the search). The free V's box at its minimum-area angle
  // (about 200 x 68 texels) is 0.4-0.5 of that page, the exact triangle's 140 x 140 is larger but
  // exact. angle_search_box_share 0.3 searches the V alone (11 candidates, not the triangle), with
  // the layout of the search by count; 0.9 (no free chart's box is that large) and 0 (off, the
  // default) search nothing; the opened search's work cap applies.
  const std::vector<std::vector<Vec2>> polys = v_and_triangle();
  auto with = [&](const json& extra) {
    json o = {{"page_multiple", 4}, {"angle_search_max_charts", 1}};
    for (const auto& [k, v] : extra.items()) o[k] = v;
    return run_packer(kName, polygon_mesh(polys, 1024), o, turn_chart0(0.3));
  };
  auto off = with(json::object());
  EXPECT_EQ(off->report.at("angle_search_packings").get<int>(), 0);
  auto large = with({{"angle_search_box_share", 0.3}});
  expect_valid_layout(*large, 4);
  EXPECT_TRUE(large->report.at("angle_search_opened").get<bool>());
  EXPECT_EQ(large->report.at("angle_search_packings").get<int>(), 11);
  EXPECT_LT(large->report.at("page_megapixels").get<double>(), off->report.at("page_megapixels").get<double>());
  auto by_count = run_packer(kName, polygon_mesh(polys, 1024), {{"page_multiple", 4}}, turn_chart0(0.3));
  EXPECT_EQ(large->ctx.layout.wedge_uv, by_count->ctx.layout.wedge_uv);
  auto none = with({{"angle_search_box_share", 0.9}});
  EXPECT_EQ(none->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_FALSE(none->report.at("angle_search_opened").get<bool>());
  EXPECT_EQ(none->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  auto capped = with({{"angle_search_box_share", 0.3}, {"angle_search_opened_max_work", 0.34}});
  EXPECT_TRUE(capped->report.at("angle_search_capped").get<bool>());
  EXPECT_EQ(capped->report.at("angle_search_packings").get<int>(), 0);
}

TEST(PackersSquareTetris, AnOpenedSearchSkipsAFreeTrialThatStartsLarger) {
  // Chart 0: a V (two 200 x 10 arms 30 degrees apart) turned by `turn` in the input, one corner
  // moved by a quarter texel (exact, partly resampled: the free trial frees it); chart 1: an exact
  // right triangle with 140-texel legs (AngleSearchRunsInTheFreeTrial's atlas). Only the free
  // trial's V can be searched. Turned by 0.2 rad the freed V packs larger than the exact one
  // (0.030528 MP exact): an opened search (angle_search_max_charts 1, angle_search_box_share 0.3)
  // skips the trial's search and the page stays; the search by count (16) still searches it.
  // Turned by 0.3 rad the freed V starts smaller, and the opened search runs and keeps it.
  auto run = [](double turn, const json& o) {
    std::vector<Vec2> v = v_polygon(200, 10, 30, {0, 0});
    for (Vec2& p : v) p = packing::rotate(p, turn) + Vec2(400.3, 300.7);
    auto edit = [](Atlas& a) {
      for (size_t f = 0; f < a.face_chart.size(); ++f)
        if (a.face_chart[f] == 0) {
          a.wedge_uv[static_cast<size_t>(a.face_wedge[f][1])] += Vec2(0.25, -0.1);
          break;
        }
    };
    json all = {{"page_multiple", 4}, {"free_trial_gain", 0.0}};
    for (const auto& [k, x] : o.items()) all[k] = x;
    return run_packer(kName, polygon_mesh({v, {{10, 10}, {150, 10}, {10, 150}}}, 1024), all, edit);
  };
  const json opened = {{"angle_search_max_charts", 1}, {"angle_search_box_share", 0.3}};
  auto off = run(0.2, {{"angle_search_max_charts", 0}});
  EXPECT_FALSE(off->report.at("free_trial_kept").get<bool>());  // with gain 0: the freed V packs larger
  EXPECT_DOUBLE_EQ(off->report.at("page_megapixels").get<double>(), 0.030528);
  auto skipped = run(0.2, opened);
  EXPECT_TRUE(skipped->report.at("angle_search_free_trial_skipped").get<bool>());
  EXPECT_EQ(skipped->report.at("angle_search_packings").get<int>(), 0);
  EXPECT_EQ(skipped->ctx.layout.wedge_uv, off->ctx.layout.wedge_uv);
  auto by_count = run(0.2, json::object());
  EXPECT_FALSE(by_count->report.at("angle_search_free_trial_skipped").get<bool>());
  EXPECT_EQ(by_count->report.at("angle_search_packings").get<int>(), 11);
  auto smaller = run(0.3, opened);
  EXPECT_FALSE(smaller->report.at("angle_search_free_trial_skipped").get<bool>());
  EXPECT_EQ(smaller->report.at("angle_search_packings").get<int>(), 11);
  EXPECT_TRUE(smaller->report.at("free_trial_kept").get<bool>());
  expect_valid_layout(*smaller, 4);
}

TEST(PackersSquareTetris, AngleSearchOptionsAreDeclaredWithRanges) {
  Registry::instance().load_plugins();
  const StageInfo* info = Registry::instance().find(kName);
  ASSERT_NE(info, nullptr);
  auto check = [&](const std::string& key, const json& v) {
    for (const OptionSpec& o : info->options)
      if (o.key == key) return check_option_value(o, v);
    ADD_FAILURE() << "no option " << key;
    return std::string();
  };
  EXPECT_EQ(check("angle_step_degrees", 0.25), "= 0.25 outside [0.5, 45]");
  EXPECT_EQ(check("angle_step_degrees", 7.5), "");
  EXPECT_EQ(check("angle_search_max_charts", -1), "= -1 outside [0, 1000]");
  EXPECT_EQ(check("angle_search_max_charts", 0), "");  // off
  EXPECT_EQ(check("angle_search_rounds", 0), "= 0 outside [1, 8]");
  EXPECT_EQ(check("angle_search_packing_below", 1.5), "= 1.5 outside [0, 1]");
  EXPECT_EQ(check("angle_search_packing_below", 0.0), "");  // off
  EXPECT_EQ(check("angle_search_opened_max_work", -1), "= -1 outside [0, 1e+06]");
  EXPECT_EQ(check("angle_search_box_share", 1.5), "= 1.5 outside [0, 1]");
  EXPECT_EQ(check("angle_search_box_share", 0.0), "");  // off
  EXPECT_EQ(check("wide_page_trials", 7), "= 7 outside [0, 6]");
  EXPECT_EQ(check("wide_page_trials", 0), "");  // off
  EXPECT_EQ(check("width_refine_max_charts", -1), "= -1 outside [0, 1e+08]");
}
