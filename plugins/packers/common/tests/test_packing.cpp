// Chart preparation, exactness anchoring and page sizing of the shared packer library.
#include "texdefrag/packers/packing.h"
#include "texdefrag/util/parallel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <mutex>

using namespace texdefrag;
using namespace texdefrag::packing;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// One chart per quad (2 triangles) given by its 4 corners; atlas only, no mesh.
Atlas quad_atlas(const std::vector<std::array<Vec2, 4>>& quads) {
  Atlas a;
  for (const auto& q : quads) {
    const int w0 = static_cast<int>(a.wedge_uv.size());
    for (const Vec2& p : q) {
      a.wedge_uv.push_back(p);
      a.wedge_vertex.push_back(static_cast<int>(a.wedge_vertex.size()));
    }
    a.face_wedge.push_back({w0, w0 + 1, w0 + 2});
    a.face_wedge.push_back({w0, w0 + 2, w0 + 3});
    a.face_chart.push_back(a.num_charts);
    a.face_chart.push_back(a.num_charts);
    a.chart_page.push_back(0);
    ++a.num_charts;
  }
  return a;
}

std::array<Vec2, 4> rect(double x, double y, double w, double h, double angle = 0) {
  std::array<Vec2, 4> r{Vec2(0, 0), Vec2(w, 0), Vec2(w, h), Vec2(0, h)};
  for (Vec2& p : r) {
    const double c = std::cos(angle), s = std::sin(angle);
    p = Vec2(c * p.x() - s * p.y() + x, s * p.x() + c * p.y() + y);
  }
  return r;
}

}  // namespace

TEST(PackersCommon, RoundPageSide) {
  CommonSettings s;
  s.page_multiple = 32;
  s.max_page_size = 100;
  EXPECT_EQ(round_page_side(1, s), 32);
  EXPECT_EQ(round_page_side(32, s), 32);
  EXPECT_EQ(round_page_side(33, s), 64);
  EXPECT_EQ(round_page_side(99, s), 100);  // capped: never beyond max_page_size
  s.power_of_two = true;
  EXPECT_EQ(round_page_side(33, s), 64);
  EXPECT_EQ(round_page_side(64, s), 64);
  EXPECT_EQ(round_page_side(0, s), 1);
}

TEST(PackersCommon, FootprintsOfAxisAlignedQuad) {
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(10.5, 20.25, 5, 3)});
  CommonSettings s;
  const PackInput in = prepare_charts(ctx, s, "packers.test");
  ASSERT_EQ(in.charts.size(), 1u);
  const PackChart& c = in.charts[0];
  EXPECT_TRUE(c.exact);  // no mesh: the atlas is the input, grid offset 0
  EXPECT_EQ(c.grid_offset, Vec2(0, 0));
  EXPECT_DOUBLE_EQ(c.uv_area, 15.0);
  // x in [10.5, 15.5] -> cells [10, 16) (6), y in [20.25, 23.25] -> cells [20, 24) (4).
  EXPECT_EQ(c.w[0], 6);
  EXPECT_EQ(c.h[0], 4);
  EXPECT_EQ(c.ox[0], 10);
  EXPECT_EQ(c.oy[0], 20);
  // Turned by 90 degrees: x = -y in [-23.25, -20.25] -> cells [-24, -20) (4), y = x -> [10, 16) (6).
  EXPECT_EQ(c.w[1], 4);
  EXPECT_EQ(c.h[1], 6);
  EXPECT_EQ(c.ox[1], -24);
  const Placement p{0, 100, 200, 1};
  const Vec2 moved = place_point(c, p, c.base[0]);  // (10.5, 20.25) -> (-20.25, 10.5) + (124, 190)
  EXPECT_EQ(moved, Vec2(103.75, 200.5));
  const Mask m = c.raster(0);
  int n = 0;
  for (uint8_t v : m.cells) n += v;
  EXPECT_EQ(n, 24);  // every cell of the box is touched by the rectangle
}

TEST(PackersCommon, FreeRotationToMinAreaRectangle) {
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(50, 50, 40, 10, kPi / 5)});
  TexturedMesh mesh;  // the mesh's input UVs differ (the chart was "merged"): not exact
  CommonSettings s;
  s.free_rotation = true;
  s.exact_fraction = 1.0;
  // Without a mesh every chart is exact and keeps its angle.
  PackInput in = prepare_charts(ctx, s, "packers.test");
  EXPECT_TRUE(in.charts[0].exact);
  EXPECT_EQ(in.charts[0].angle, 0.0);
  // Make it non-exact: build the same atlas against a mesh whose UVs are elsewhere (scaled).
  mesh.pages.push_back(Page{"p", "p.png", 1000, 1000});
  for (int f = 0; f < 2; ++f) {
    Face fc;
    fc.page = 0;
    fc.vt = {3 * f, 3 * f + 1, 3 * f + 2};
    mesh.faces.push_back(fc);
    for (int k = 0; k < 3; ++k) {
      const Vec2 uv = ctx.atlas.wedge_uv[static_cast<size_t>(ctx.atlas.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
      mesh.texcoords.push_back(uv * 0.0011);  // 1.1x the atlas: no face is rigidly the input
    }
  }
  ctx.mesh = &mesh;
  in = prepare_charts(ctx, s, "packers.test");
  const PackChart& c = in.charts[0];
  EXPECT_FALSE(c.exact);
  EXPECT_NEAR(c.angle, -kPi / 5, 1e-9);
  EXPECT_LE(c.w[0] * c.h[0], 42 * 12);  // 40 x 10 after rotation, plus partial cells
  // With free rotation off it stays axis-aligned (bigger box).
  s.free_rotation = false;
  in = prepare_charts(ctx, s, "packers.test");
  EXPECT_EQ(in.charts[0].angle, 0.0);
  EXPECT_GT(in.charts[0].w[0] * in.charts[0].h[0], 42 * 12);
}

TEST(PackersCommon, GridOffsetFromFractionalMerge) {
  // The atlas is the input moved by (0.25, 0.5) (e.g. a merger moved the chart): the packer must
  // undo the fraction so the input texel grid lands on the output grid.
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(10.25, 20.5, 4, 4)});
  TexturedMesh mesh;
  mesh.pages.push_back(Page{"p", "p.png", 100, 100});
  for (int f = 0; f < 2; ++f) {
    Face fc;
    fc.page = 0;
    fc.vt = {3 * f, 3 * f + 1, 3 * f + 2};
    mesh.faces.push_back(fc);
    for (int k = 0; k < 3; ++k) {
      const Vec2 uv = ctx.atlas.wedge_uv[static_cast<size_t>(ctx.atlas.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
      mesh.texcoords.push_back((uv - Vec2(3.25, 1.5)) / 100.0);
    }
  }
  ctx.mesh = &mesh;
  CommonSettings s;
  const PackInput in = prepare_charts(ctx, s, "packers.test");
  const PackChart& c = in.charts[0];
  EXPECT_TRUE(c.exact);
  EXPECT_NEAR(c.grid_offset.x(), 0.25, 1e-9);
  EXPECT_NEAR(c.grid_offset.y(), 0.5, 1e-9);
  for (int q = 0; q < 4; ++q) {
    const Vec2 out = place_point(c, Placement{0, 7, 9, q}, c.base[0]);
    const Vec2 inp = mesh.corner_texel(0, 0);
    const Vec2 t = out - rotate90(inp, q);
    EXPECT_NEAR(t.x(), std::round(t.x()), 1e-9) << q;
    EXPECT_NEAR(t.y(), std::round(t.y()), 1e-9) << q;
  }
}

TEST(PackersCommon, WholeTexelRectangleCoversItsArea) {
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(3, 4, 10, 5)});
  CommonSettings s;
  const PackInput in = prepare_charts(ctx, s, "packers.test");
  const PackChart& c = in.charts[0];
  EXPECT_EQ(c.w[0], 10);
  EXPECT_EQ(c.h[0], 5);
  EXPECT_EQ(c.w[1], 5);
  EXPECT_EQ(c.h[1], 10);
  const Mask m = c.raster(0);
  int n = 0;
  for (uint8_t v : m.cells) n += v;
  EXPECT_EQ(n, 50);
}

TEST(PackersCommon, SharedWedgeIsAnError) {
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(0, 0, 2, 2), rect(5, 5, 2, 2)});
  ctx.atlas.face_wedge[2][0] = 0;  // chart 1 uses a wedge of chart 0
  CommonSettings s;
  EXPECT_THROW(prepare_charts(ctx, s, "packers.test"), StageError);
}

TEST(PackersCommon, TooLargeChartNamesTheChart) {
  StageContext ctx;
  ctx.atlas = quad_atlas({rect(0, 0, 2, 2), rect(0, 0, 300, 20)});
  CommonSettings s;
  s.max_page_size = 128;
  const PackInput in = prepare_charts(ctx, s, "packers.test");
  try {
    check_chart_sizes(in, s, "packers.test");
    FAIL() << "expected StageError";
  } catch (const StageError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("packers.test: chart 1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("300 x 20"), std::string::npos) << msg;
    EXPECT_NE(msg.find("128"), std::string::npos) << msg;
  }
}

TEST(PackersCommon, InitialWidthFromArea) {
  CommonSettings s;
  EXPECT_EQ(initial_page_width(1000.0 * 1000.0, 10, 1.0, s), 1024);
  EXPECT_EQ(initial_page_width(100.0, 500, 1.0, s), 512);  // at least the widest chart
  EXPECT_EQ(initial_page_width(1e12, 10, 1.0, s), 8192);   // at most max_page_size
}

TEST(PackersCommon, PlaceOnPagesFillsInOrderAndOpensPages) {
  // Pages hold a capacity; a chart goes to the first page with room, else to a new page.
  std::vector<int> room;
  auto make = [] { return 10; };
  auto put = [&](int size) {
    return place_on_pages(room, make, [&](size_t p) {
      if (room[p] < size) return false;
      room[p] -= size;
      return true;
    }, "packers.test", size, 10);
  };
  EXPECT_EQ(put(6), 0u);
  EXPECT_EQ(put(6), 1u);  // page 0 has 4 left
  EXPECT_EQ(put(3), 0u);
  EXPECT_EQ(put(4), 1u);
  EXPECT_EQ(room, (std::vector<int>{1, 0}));
  try {
    put(11);  // refused by a new page too
    FAIL() << "no error";
  } catch (const StageError& e) {
    EXPECT_STREQ(e.what(), "packers.test: chart 11 fits no page of width 10");
  }
}

TEST(PackersCommon, TrialBoardStopsOnlyTrialsThatCannotWin) {
  // Three width trials; trial 1 packed everything on one page of 100 texels^2.
  TrialBoard board(3);
  PackResult one_page;
  one_page.pages = 1;
  one_page.sizes = {{10, 10}};
  PackResult two_pages;
  two_pages.pages = 2;
  two_pages.sizes = {{5, 5}, {5, 5}};
  board.record(2, two_pages);  // not a single page: bounds nothing
  EXPECT_FALSE(board.beaten(0, 1, 1000.0));
  board.record(1, one_page);
  EXPECT_FALSE(board.beaten(0, 1, 100.0));  // an earlier width keeps a tie
  EXPECT_TRUE(board.beaten(0, 1, 101.0));
  EXPECT_TRUE(board.beaten(0, 2, 1.0));     // a second page loses to a single page
  EXPECT_TRUE(board.beaten(2, 1, 100.0));   // a later width loses a tie
  EXPECT_FALSE(board.beaten(2, 1, 99.0));
  EXPECT_FALSE(board.beaten(1, 1, 1e9));    // a trial is not bounded by its own result
}

TEST(PackersCommon, TrialBoardSeededByAnEarlierPackingStopsTrialsThatCannotBeatIt) {
  // An earlier packing (another tail order) gave one page of 100 texels^2: a trial must use less.
  TrialBoard board(2);
  board.seed(100.0);
  EXPECT_TRUE(board.beaten(0, 1, 100.0));  // a tie keeps the earlier packing
  EXPECT_FALSE(board.beaten(0, 1, 99.0));
  EXPECT_TRUE(board.beaten(1, 2, 1.0));    // a second page loses to a single page
  PackResult one_page;
  one_page.pages = 1;
  one_page.sizes = {{9, 9}};
  board.record(0, one_page);               // and the trials still bound each other
  EXPECT_TRUE(board.beaten(1, 1, 81.0));
  EXPECT_FALSE(board.beaten(1, 1, 80.0));
}

TEST(PackersCommon, TrialBoardWithABarStopsOnlyTrialsOverIt) {
  // A caller keeps the packing only as one page of at most 100 texels^2 (block-grid trial): a
  // trial needing exactly 100 still counts, one over it or with a second page cannot be kept.
  TrialBoard board(2);
  board.seed(100.0, false);
  EXPECT_FALSE(board.beaten(0, 1, 100.0));
  EXPECT_TRUE(board.beaten(0, 1, 100.5));
  EXPECT_TRUE(board.beaten(1, 2, 1.0));
  PackResult one_page;
  one_page.pages = 1;
  one_page.sizes = {{9, 9}};
  board.record(0, one_page);  // the trials still bound each other
  EXPECT_TRUE(board.beaten(1, 1, 81.0));
  EXPECT_FALSE(board.beaten(1, 1, 80.0));
}

namespace {

/// A fake width trial for pack_widths: one chart of 1 x 1 texels placed so that page 0 is
/// width x height texels (page_multiple 1, gutter 0), on `pages` pages.
PackResult fake_trial(int width, int height, int pages = 1) {
  PackResult r;
  r.placements = {Placement{0, width - 1, height - 1, 0}};
  r.pages = pages;
  return r;
}

struct FakeInput {
  PackInput in;
  CommonSettings s;
  FakeInput() {
    in.charts.resize(1);
    s.gutter = 0;
    s.page_multiple = 1;
  }
};

}  // namespace

TEST(PackersCommon, PackWidthsRunsTheBesideJobWithTheLeaderOfTheFinishedTrials) {
  // Page heights per width: 40 -> 40 x 40, 30 -> two pages, 20 -> 20 x 100, 50 -> 50 x 20 (the
  // best: 1000 texels^2). With one thread the beside job runs once, after every trial, with the
  // chosen width's result, or with the incumbent (-1) when no trial beats it (ties keep it).
  FakeInput f;
  const std::vector<int> widths{40, 30, 20, 50};
  auto trial = [](int w, TrialBound&) {
    return w == 30 ? fake_trial(30, 30, 2) : fake_trial(w, w == 40 ? 40 : w == 20 ? 100 : 20);
  };
  set_thread_count(1);
  struct Call {
    int leader;
    double area;
    const PackResult* result;
  };
  std::vector<Call> calls;
  const BesideJob job = [&](int leader, const PackResult& r) { calls.push_back({leader, r.total_area(), &r}); };
  int chosen = 0;
  const PackResult best = pack_widths(f.in, f.s, widths, trial, &chosen, nullptr, -1, job);
  EXPECT_EQ(chosen, 50);
  EXPECT_EQ(best.total_area(), 1000.0);
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0].leader, 3);
  EXPECT_EQ(calls[0].area, 1000.0);
  for (const auto& [area, leader] : std::vector<std::pair<int, int>>{{900, -1}, {1000, -1}, {1001, 3}}) {
    SCOPED_TRACE("incumbent " + std::to_string(area));
    PackResult incumbent;
    incumbent.pages = 1;
    incumbent.sizes = {{area, 1}};
    calls.clear();
    pack_widths(f.in, f.s, widths, trial, &chosen, &incumbent, -1, job);
    ASSERT_EQ(calls.size(), 1u);
    EXPECT_EQ(calls[0].leader, leader);
    if (leader < 0) {
      EXPECT_EQ(calls[0].result, &incumbent);
    }
  }
  set_thread_count(0);
}

TEST(PackersCommon, PackWidthsBesideJobMayRunBeforeABetterTrialEnds) {
  // Two threads, widths 10 (one page of 100 texels^2, at once) and 20 (one page of 25, ending
  // only after the beside job ran): the job starts once both trials started, and sees only the
  // first as finished, so its leader (0) is not the chosen width (20). The caller must check the
  // leader against the final result (square_tetris's block-grid trial does).
  FakeInput f;
  std::mutex m;
  std::condition_variable cv;
  bool job_ran = false;
  auto trial = [&](int w, TrialBound&) {
    if (w == 20) {
      std::unique_lock<std::mutex> lock(m);
      cv.wait(lock, [&] { return job_ran; });
      return fake_trial(5, 5);
    }
    return fake_trial(10, 10);
  };
  int leader = -2;
  const BesideJob job = [&](int l, const PackResult&) {
    std::lock_guard<std::mutex> lock(m);
    leader = l;
    job_ran = true;
    cv.notify_all();
  };
  set_thread_count(2);
  int chosen = 0;
  pack_widths(f.in, f.s, {10, 20}, trial, &chosen, nullptr, -1, job);
  set_thread_count(0);
  EXPECT_EQ(leader, 0);
  EXPECT_EQ(chosen, 20);
}
