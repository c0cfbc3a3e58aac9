// Tests of texture resampling (framework/src/texture/resample.cpp) on hand-built atlases over tiny
// in-memory images, with texel values computed by hand from the conventions of docs/texture.md:
// texel (i, j) of a W x H page has its centre at (i + 0.5, H - j - 0.5) in texel space (y up).
#include "texdefrag/texture/resample.h"
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/util/parallel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

namespace texdefrag {
namespace {

using Tri = std::array<Vec2, 3>;

Image make_image(int w, int h, int channels, const std::function<int(int x, int y, int c)>& value) {
  Image im;
  im.width = w;
  im.height = h;
  im.channels = channels;
  im.pixels.resize(static_cast<size_t>(w * h * channels));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) im.at(x, y)[c] = static_cast<uint8_t>(value(x, y, c));
  return im;
}

/// A pattern with no two equal neighbours, so a wrong texel shows.
Image pattern(int w, int h, int channels = 3) {
  return make_image(w, h, channels, [](int x, int y, int c) { return (x * 37 + y * 101 + c * 59 + x * y * 13) % 251; });
}

/// Hand-built mesh + atlas + layout: every face has its own three wedges.
struct Scene {
  TexturedMesh mesh;
  Atlas atlas;
  Layout layout;
  std::vector<Image> inputs;

  int add_input_page(Image img) {
    Page p;
    p.material = "m" + std::to_string(mesh.pages.size());
    p.width = img.width;
    p.height = img.height;
    mesh.pages.push_back(p);
    inputs.push_back(std::move(img));
    return static_cast<int>(mesh.pages.size()) - 1;
  }
  int add_output_page(int w, int h) {
    layout.pages.push_back({w, h});
    return static_cast<int>(layout.pages.size()) - 1;
  }
  int add_chart(int in_page, int out_page) {
    atlas.chart_page.push_back(in_page);
    layout.chart_page.push_back(out_page);
    return atlas.num_charts++;
  }
  /// One face: input corners in texels of the chart's input page, output corners in texels of its
  /// output page.
  void add_face(int chart, const Tri& in, const Tri& out) {
    const int page = atlas.chart_page[static_cast<size_t>(chart)];
    const Page& P = mesh.pages[static_cast<size_t>(page)];
    Face f;
    f.page = page;
    f.source_line = static_cast<int>(mesh.faces.size()) + 1;
    for (int k = 0; k < 3; ++k) {
      const auto sk = static_cast<size_t>(k);
      f.v[sk] = static_cast<int>(mesh.positions.size());
      mesh.positions.emplace_back(in[sk].x(), in[sk].y(), 0.0);
      f.vt[sk] = static_cast<int>(mesh.texcoords.size());
      mesh.texcoords.emplace_back(in[sk].x() / P.width, in[sk].y() / P.height);
    }
    mesh.faces.push_back(f);
    std::array<int, 3> w{};
    for (int k = 0; k < 3; ++k) {
      const auto sk = static_cast<size_t>(k);
      w[sk] = static_cast<int>(atlas.wedge_uv.size());
      atlas.wedge_uv.push_back(in[sk]);
      atlas.wedge_vertex.push_back(f.v[sk]);
      layout.wedge_uv.push_back(out[sk]);
    }
    atlas.face_wedge.push_back(w);
    atlas.face_chart.push_back(chart);
  }
  /// Two triangles covering the axis-aligned rectangle [x0, x1] x [y0, y1] of the input, mapped by
  /// `map` (input texel point -> output texel point).
  void add_rect(int chart, double x0, double y0, double x1, double y1, const std::function<Vec2(const Vec2&)>& map) {
    const Vec2 a(x0, y0), b(x1, y0), c(x1, y1), d(x0, y1);
    add_face(chart, {a, b, c}, {map(a), map(b), map(c)});
    add_face(chart, {a, c, d}, {map(a), map(c), map(d)});
  }
  std::vector<Image> run(const ResampleOptions& opt, ResampleStats* stats = nullptr,
                         const ProgressFn& progress = nullptr) const {
    return resample_atlas(mesh, inputs, atlas, layout, opt, stats, progress);
  }
};

/// Options of the hand-checked sampling tests: plain sampling (no least-squares fit).
ResampleOptions opts(Filter filter, GutterFill fill) {
  ResampleOptions o;
  o.filter = filter;
  o.fill = fill;
  o.fit = TexelFit::Sample;
  return o;
}

bool same_texel(const Image& a, int ax, int ay, const Image& b, int bx, int by) {
  return std::equal(a.at(ax, ay), a.at(ax, ay) + a.channels, b.at(bx, by));
}

/// Texels whose colour differs from `bg` in a render with GutterFill::None (the covered set, when
/// the input never has colour `bg`).
std::vector<char> covered_mask(const Image& im, const std::array<uint8_t, 4>& bg) {
  std::vector<char> m(static_cast<size_t>(im.width * im.height), 0);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      m[static_cast<size_t>(y * im.width + x)] = !std::equal(im.at(x, y), im.at(x, y) + im.channels, bg.begin());
  return m;
}

// ------------------------------------------------------------------------------------------------

TEST(TextureResample, SingleTriangleCoverageByHand) {
  // Output triangle (0,0) (4,0) (0,4) on a 4x4 page. Texel (i, j) has centre (i+.5, 3.5-j), so
  // x + y = 4 + i - j: interior when i < j (6 texels; the hypotenuse i == j is not owned by this
  // triangle under the top-left rule); border when the L-inf distance (i - j) / 2 < 1, i.e.
  // i - j in {0, 1} (7 texels); texels (2,0), (3,0), (3,1) stay background.
  Scene s;
  const int in = s.add_input_page(make_image(4, 4, 1, [](int, int, int) { return 200; }));
  const int out = s.add_output_page(4, 4);
  const int c = s.add_chart(in, out);
  const Tri t{Vec2(0, 0), Vec2(4, 0), Vec2(0, 4)};
  s.add_face(c, t, t);
  ResampleOptions o = opts(Filter::Bilinear, GutterFill::None);
  o.background[0] = 7;
  ResampleStats st;
  const auto pages = s.run(o, &st);
  ASSERT_EQ(pages.size(), 1u);
  ASSERT_EQ(pages[0].channels, 1);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      const int expected = (i - j >= 2) ? 7 : 200;
      EXPECT_EQ(pages[0].at(i, j)[0], expected) << "texel " << i << "," << j;
    }
  EXPECT_EQ(st.texels_written, 13u);
  EXPECT_EQ(st.faces_copied, 1u);
  EXPECT_EQ(st.texels_copied, 13u);
}

TEST(TextureResample, SharedEdgeTexelsHaveOneOwner) {
  // The 4x4 page split along x + y = 4 into T1 (0,0) (4,0) (0,4) and T2 (4,0) (4,4) (0,4), from
  // input regions of value 50 and 150. Texel centres on the diagonal (i == j) belong to T2 (its
  // inward normal points to +x: top-left rule), whichever triangle is drawn first.
  const Image img = make_image(8, 4, 1, [](int x, int, int) { return x < 4 ? 50 : 150; });
  for (int order = 0; order < 2; ++order) {
    Scene s;
    const int in = s.add_input_page(img);
    const int out = s.add_output_page(4, 4);
    const int c1 = s.add_chart(in, out), c2 = s.add_chart(in, out);
    const Tri t1{Vec2(0, 0), Vec2(4, 0), Vec2(0, 4)}, t2{Vec2(4, 0), Vec2(4, 4), Vec2(0, 4)};
    const Tri t2_in{Vec2(8, 0), Vec2(8, 4), Vec2(4, 4)};
    if (order == 0) {
      s.add_face(c1, t1, t1);
      s.add_face(c2, t2_in, t2);
    } else {
      s.add_face(c2, t2_in, t2);
      s.add_face(c1, t1, t1);
    }
    ResampleStats st;
    const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None), &st);
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) EXPECT_EQ(pages[0].at(i, j)[0], i < j ? 50 : 150) << order << ": " << i << "," << j;
    EXPECT_EQ(st.texels_written, 16u);
    EXPECT_EQ(st.faces_copied, 2u);
  }
}

TEST(TextureResample, IdentityLayoutIsBitExact) {
  Scene s;
  const int in = s.add_input_page(pattern(8, 8));
  const int out = s.add_output_page(8, 8);
  const int c = s.add_chart(in, out);
  s.add_rect(c, 0, 0, 8, 8, [](const Vec2& p) -> Vec2 { return p; });
  ResampleStats st;
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::PullPush), &st);
  ASSERT_EQ(pages[0].width, 8);
  EXPECT_EQ(pages[0].pixels, s.inputs[0].pixels);
  EXPECT_EQ(st.faces_copied, 2u);
  EXPECT_EQ(st.faces_resampled, 0u);
  EXPECT_EQ(st.texels_written, 64u);
  EXPECT_EQ(st.texels_copied, 64u);
}

TEST(TextureResample, IdentityInsideChartWithBicubicStillCopies) {
  // A chart [2,6]^2 on a 12x10 page: the 16 interior texels and the border ring reproduce the input.
  Scene s;
  const int in = s.add_input_page(pattern(12, 10));
  const int c = s.add_chart(in, s.add_output_page(12, 10));
  s.add_rect(c, 2, 2, 6, 6, [](const Vec2& p) -> Vec2 { return p; });
  ResampleStats st;
  const auto pages = s.run(opts(Filter::Bicubic, GutterFill::PullPush), &st);
  // texel columns 1..6 and rows (10-1-y) for y in 1..6 -> rows 3..8 are within 1 texel of the chart
  for (int j = 3; j <= 8; ++j)
    for (int i = 1; i <= 6; ++i) EXPECT_TRUE(same_texel(pages[0], i, j, s.inputs[0], i, j)) << i << "," << j;
  EXPECT_EQ(st.faces_copied, 2u);
  EXPECT_EQ(st.texels_written, 36u);
}

TEST(TextureResample, WholeTexelTranslationIsCopied) {
  Scene s;
  const int in = s.add_input_page(pattern(8, 8));
  const int c = s.add_chart(in, s.add_output_page(10, 12));
  // input [1,4] x [1,5] moved by (+5, +6) onto a 10x12 page
  s.add_rect(c, 1, 1, 4, 5, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 5, p.y() + 6); });
  ResampleStats st;
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::PullPush), &st);
  // output centre (i+.5, 11.5-j) -> input (i-4.5, 5.5-j): input column i-5, input row 8-1-(5-j) = j+2
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 10; ++i) {
      const double x = i + 0.5, y = 11.5 - j;
      if (!(x > 6 && x < 9 && y > 7 && y < 11)) continue;  // interior of the moved rectangle
      EXPECT_TRUE(same_texel(pages[0], i, j, s.inputs[0], i - 5, j + 2)) << i << "," << j;
    }
  EXPECT_EQ(st.faces_copied, 2u);
  EXPECT_EQ(st.texels_copied, st.texels_written);
}

TEST(TextureResample, RepackOfOverlappingChartsAndAZeroAreaFaceCopiesEveryTexel) {
  // What configs/repack.json does to a producer's atlas (issue 12): charts moved by whole texels.
  // Chart A: input [1,5]^2 -> output +(8, 2), i.e. [9,13] x [3,7]; chart B overlaps A in the input,
  // [3,7]^2 -> output +(-2, 7), i.e. [1,5] x [10,14]. A also holds a zero-UV-area face (drawn
  // first): the segment y = 0.75, x in [1, 5], a quarter texel below A's edge, so it is nearer to
  // the texels below that edge than A's own triangles are (before: those texels took the
  // segment's centroid colour instead of their own). Every texel within one texel of a chart (the
  // chart's rectangle grown by one texel: texel columns x0-1..x1, texel-space rows y0-1..y1) must
  // equal the input texel it came from, with the default fit and fill of repack.json.
  const Image img = pattern(16, 16);
  Scene s;
  const int in = s.add_input_page(img);
  const int out = s.add_output_page(16, 16);
  const int a = s.add_chart(in, out), b = s.add_chart(in, out);
  const auto move = [](double dx, double dy) { return [=](const Vec2& p) -> Vec2 { return Vec2(p.x() + dx, p.y() + dy); }; };
  const Vec2 s0(1, 0.75), s1(5, 0.75), s2(3, 0.75);
  s.add_face(a, {s0, s1, s2}, {move(8, 2)(s0), move(8, 2)(s1), move(8, 2)(s2)});
  s.add_rect(a, 1, 1, 5, 5, move(8, 2));
  s.add_rect(b, 3, 3, 7, 7, move(-2, 7));
  ResampleStats st;
  ResampleOptions o;  // least-squares fit, pull-push: as repack.json
  const auto pages = s.run(o, &st);
  const auto expect_copied = [&](int x0, int y0, int x1, int y1, int dx, int dy) {
    for (int x = x0 - 1; x <= x1; ++x)
      for (int y = y0 - 1; y <= y1; ++y)  // texel-space texel (x, y) is image row 15 - y
        EXPECT_TRUE(same_texel(pages[0], x + dx, 15 - (y + dy), img, x, 15 - y)) << "input texel " << x << "," << y;
  };
  expect_copied(1, 1, 5, 5, 8, 2);
  expect_copied(3, 3, 7, 7, -2, 7);
  EXPECT_EQ(st.faces_copied, 5u);
  EXPECT_EQ(st.faces_resampled, 0u);
  EXPECT_EQ(st.texels_written, 72u);  // two 6 x 6 grown rectangles
  EXPECT_EQ(st.texels_copied, st.texels_written);
  EXPECT_EQ(st.texels_fitted, 0u);
}

TEST(TextureResample, ZeroAreaFacesNeverOverwriteARealFacesBorder) {
  // A segment face that is not a whole-texel move (scaled 2x) beside a copied rectangle, nearer to
  // the texels below the rectangle's edge than the rectangle: drawn first or last, those texels
  // keep the rectangle's copy (the segment only colours texels no real face reaches).
  const Image img = pattern(16, 16);
  for (const bool segment_first : {true, false}) {
    Scene s;
    const int in = s.add_input_page(img);
    const int c = s.add_chart(in, s.add_output_page(16, 16));
    const auto seg = [&] { s.add_face(c, {Vec2(1, 0.9), Vec2(3, 0.9), Vec2(2, 0.9)}, {Vec2(4, 4.8), Vec2(8, 4.8), Vec2(6, 4.8)}); };
    if (segment_first) seg();
    s.add_rect(c, 1, 1, 5, 5, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 4, p.y() + 4); });
    if (!segment_first) seg();
    ResampleStats st;
    const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None), &st);
    // texel-space row y = 4 (centre 4.5: 0.3 from the segment, 0.5 from the rectangle), columns 4..8
    for (int x = 4; x <= 8; ++x) EXPECT_TRUE(same_texel(pages[0], x, 15 - 4, img, x - 4, 15)) << x << " " << segment_first;
    EXPECT_EQ(st.faces_resampled, 1u);
  }
}

TEST(TextureResample, QuarterTurnsAreCopiedBitExact) {
  // 4x4 input with all texels distinct, the full page rotated about the page centre (2, 2).
  const Image img = make_image(4, 4, 3, [](int x, int y, int c) { return 10 * (y * 4 + x) + c; });
  for (int turns = 1; turns <= 3; ++turns) {
    Scene s;
    const int in = s.add_input_page(img);
    const int c = s.add_chart(in, s.add_output_page(4, 4));
    const auto rot = [turns](const Vec2& p) -> Vec2 {
      Vec2 d = p - Vec2(2, 2);
      for (int t = 0; t < turns; ++t) d = Vec2(-d.y(), d.x());  // counter-clockwise, y up
      return Vec2(2, 2) + d;
    };
    s.add_rect(c, 0, 0, 4, 4, rot);
    ResampleStats st;
    const auto pages = s.run(opts(Filter::Bicubic, GutterFill::None), &st);
    EXPECT_EQ(st.faces_copied, 2u) << turns;
    EXPECT_EQ(st.texels_copied, 16u) << turns;
    // Input texel (a, b) has centre (a+.5, 3.5-b); rotate it and read the output texel there.
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a) {
        const Vec2 q = rot(Vec2(a + 0.5, 3.5 - b));
        const int i = static_cast<int>(std::floor(q.x())), j = 3 - static_cast<int>(std::floor(q.y()));
        EXPECT_TRUE(same_texel(pages[0], i, j, img, a, b)) << "turns " << turns << " texel " << a << "," << b;
      }
  }
  // Hand check of one quarter turn: out[col b, row 3-a] = in[col a, row b]; e.g. input texel
  // (0, 0) (value 0) lands at output (0, 3), input texel (3, 0) (value 30) at output (0, 0).
  Scene s;
  const int in = s.add_input_page(img);
  s.add_rect(s.add_chart(in, s.add_output_page(4, 4)), 0, 0, 4, 4,
             [](const Vec2& p) -> Vec2 { return Vec2(4 - p.y(), p.x()); });
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None));
  EXPECT_EQ(pages[0].at(0, 3)[0], 0);
  EXPECT_EQ(pages[0].at(0, 0)[0], 30);
  EXPECT_EQ(pages[0].at(3, 3)[0], 120);  // input (0, 3)
}

TEST(TextureResample, HalfTexelShiftIsBilinear) {
  // Input value 3 x^2 + y in column x, row y. Shifting by +0.5 texel in x: output centre x = i+.5
  // maps to input x = i, i.e. halfway between the centres of columns i-1 and i.
  const Image img = make_image(8, 8, 1, [](int x, int y, int) { return 3 * x * x + y; });
  Scene s;
  const int in = s.add_input_page(img);
  const int c = s.add_chart(in, s.add_output_page(8, 8));
  s.add_rect(c, 1, 0, 6, 8, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 0.5, p.y()); });
  ResampleStats st;
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None), &st);
  EXPECT_EQ(st.faces_copied, 0u);
  EXPECT_EQ(st.faces_resampled, 2u);
  for (int j = 0; j < 8; ++j)
    for (int i = 2; i <= 5; ++i) {  // centres 2.5 .. 5.5 lie inside [1.5, 6.5]
      const double expected = (3.0 * (i - 1) * (i - 1) + j + 3.0 * i * i + j) / 2;
      EXPECT_EQ(pages[0].at(i, j)[0], static_cast<int>(std::floor(expected + 0.5))) << i << "," << j;
    }
  // Nearest with a 0.3-texel shift takes column i (grid x = i - 0.3 rounds to i); 0.7 takes i - 1.
  for (double shift : {0.3, 0.7}) {
    Scene n;
    const int nin = n.add_input_page(img);
    n.add_rect(n.add_chart(nin, n.add_output_page(8, 8)), 1, 0, 6, 8,
               [shift](const Vec2& p) -> Vec2 { return Vec2(p.x() + shift, p.y()); });
    const auto np = n.run(opts(Filter::Nearest, GutterFill::None));
    for (int j = 0; j < 8; ++j)
      for (int i = 2; i <= 5; ++i) {
        const int col = shift < 0.5 ? i : i - 1;
        EXPECT_EQ(np[0].at(i, j)[0], img.at(col, j)[0]) << shift << " " << i << "," << j;
      }
  }
}

TEST(TextureResample, BicubicReproducesLinearRamp) {
  // Catmull-Rom reproduces linear functions exactly; away from the clamped edges (2 texels) the
  // output is the ramp at the mapped position, up to rounding.
  const auto ramp = [](double gx, double gy) { return 5.0 * gx + 3.0 * gy + 10.0; };
  const Image img = make_image(24, 24, 1, [&](int x, int y, int) { return static_cast<int>(ramp(x, y)); });
  Scene s;
  const int in = s.add_input_page(img);
  const int c = s.add_chart(in, s.add_output_page(32, 32));
  // input [4, 20]^2 scaled by 1.5 and rotated slightly, shifted into the output page
  const double ang = 0.2, sc = 1.5;
  const auto map = [&](const Vec2& p) -> Vec2 {
    const Vec2 d = p - Vec2(12, 12);
    return Vec2(16, 16) + sc * Vec2(std::cos(ang) * d.x() - std::sin(ang) * d.y(), std::sin(ang) * d.x() + std::cos(ang) * d.y());
  };
  s.add_rect(c, 4, 4, 20, 20, map);
  for (Filter f : {Filter::Bicubic, Filter::Bilinear}) {
    const auto pages = s.run(opts(f, GutterFill::None));
    int checked = 0;
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) {
        // inverse map of the centre
        const Vec2 q = Vec2(i + 0.5, 31.5 - j) - Vec2(16, 16);
        const Vec2 p = Vec2(12, 12) + (1 / sc) * Vec2(std::cos(ang) * q.x() + std::sin(ang) * q.y(),
                                                      -std::sin(ang) * q.x() + std::cos(ang) * q.y());
        if (p.x() < 5 || p.x() > 19 || p.y() < 5 || p.y() > 19) continue;
        const double gx = p.x() - 0.5, gy = 24 - p.y() - 0.5;
        EXPECT_NEAR(pages[0].at(i, j)[0], ramp(gx, gy), 0.51) << i << "," << j;
        ++checked;
      }
    EXPECT_GT(checked, 200);
  }
}

TEST(TextureResample, BicubicOvershootIsClamped) {
  // A black/white step shifted by half a texel: Catmull-Rom overshoots below 0 and above 255;
  // the output must clamp (0 stays 0, 255 stays 255), never wrap around.
  const Image img = make_image(8, 4, 1, [](int x, int, int) { return x < 4 ? 0 : 255; });
  Scene s;
  const int in = s.add_input_page(img);
  s.add_rect(s.add_chart(in, s.add_output_page(9, 4)), 0, 0, 8, 4, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 0.5, p.y()); });
  const auto pages = s.run(opts(Filter::Bicubic, GutterFill::None));
  // Output column i samples input grid x = i - 0.5 (t = 0.5, tap weights -1/16, 9/16, 9/16, -1/16).
  EXPECT_EQ(pages[0].at(2, 1)[0], 0);    // x = 1.5: taps 0..3, all dark
  EXPECT_EQ(pages[0].at(3, 1)[0], 0);    // x = 2.5: taps 1..4, 255 * -1/16 < 0 clamps to 0
  EXPECT_EQ(pages[0].at(4, 1)[0], 128);  // x = 3.5: taps 2..5, 255 * (9/16 - 1/16) = 127.5
  EXPECT_EQ(pages[0].at(5, 1)[0], 255);  // x = 4.5: taps 3..6, 255 * 17/16 > 255 clamps to 255
}

TEST(TextureResample, PullPushKeepsCoveredTexelsAndFillsTheRest) {
  // Smooth input, a slanted chart in the middle of a 32x32 page.
  const Image img = make_image(32, 32, 3, [](int x, int y, int c) { return 40 + 4 * x + 2 * y + 10 * c; });
  Scene s;
  const int in = s.add_input_page(img);
  const int c = s.add_chart(in, s.add_output_page(32, 32));
  s.add_face(c, {Vec2(6, 5), Vec2(25, 9), Vec2(12, 27)}, {Vec2(7.3, 6.1), Vec2(24.2, 9.7), Vec2(12.5, 26.4)});
  ResampleOptions none = opts(Filter::Bilinear, GutterFill::None);
  const std::array<uint8_t, 4> bg{255, 0, 255, 255};
  std::copy(bg.begin(), bg.end(), none.background);
  const auto base = s.run(none);
  const auto mask = covered_mask(base[0], bg);
  const auto filled = s.run(opts(Filter::Bilinear, GutterFill::PullPush));
  const Image& a = base[0];
  const Image& b = filled[0];
  int covered = 0;
  int lo[3] = {255, 255, 255}, hi[3] = {0, 0, 0};
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      if (mask[static_cast<size_t>(y * 32 + x)]) {
        ++covered;
        EXPECT_TRUE(same_texel(a, x, y, b, x, y)) << x << "," << y;
        for (int ch = 0; ch < 3; ++ch) {
          lo[ch] = std::min<int>(lo[ch], a.at(x, y)[ch]);
          hi[ch] = std::max<int>(hi[ch], a.at(x, y)[ch]);
        }
      }
  ASSERT_GT(covered, 50);
  ASSERT_LT(covered, 32 * 32 / 2);
  // Filled texels are averages of covered ones: inside their range; next to the chart they are
  // close to their covered neighbours (the input changes by at most 6 per texel per channel).
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      if (mask[static_cast<size_t>(y * 32 + x)]) continue;
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_GE(b.at(x, y)[ch], lo[ch]);
        EXPECT_LE(b.at(x, y)[ch], hi[ch]);
      }
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= 32 || ny >= 32 || !mask[static_cast<size_t>(ny * 32 + nx)]) continue;
          for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(b.at(x, y)[ch], b.at(nx, ny)[ch], 24) << x << "," << y;
        }
    }
  // A constant input fills the whole page with that constant.
  Scene k;
  const int kin = k.add_input_page(make_image(16, 16, 3, [](int, int, int ch) { return 90 + ch; }));
  k.add_face(k.add_chart(kin, k.add_output_page(20, 20)), {Vec2(1, 1), Vec2(6, 1), Vec2(1, 6)},
             {Vec2(3, 3), Vec2(8, 3), Vec2(3, 8)});
  const auto kp = k.run(opts(Filter::Bilinear, GutterFill::PullPush));
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x)
      for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(kp[0].at(x, y)[ch], 90 + ch) << x << "," << y;
}

TEST(TextureResample, FillBlocksFlattensEmptyBlocksAndSmoothsPartlyWrittenOnes) {
  // A slanted chart on a 32x32 page (4 x 4 JPEG blocks of 8 x 8) over a busy input.
  Scene s;
  const int in = s.add_input_page(pattern(32, 32));
  const int c = s.add_chart(in, s.add_output_page(32, 32));
  s.add_face(c, {Vec2(6, 5), Vec2(25, 9), Vec2(12, 27)}, {Vec2(7.3, 6.1), Vec2(24.2, 9.7), Vec2(12.5, 26.4)});
  ResampleOptions none = opts(Filter::Bilinear, GutterFill::None);
  const std::array<uint8_t, 4> bg{255, 0, 255, 255};
  std::copy(bg.begin(), bg.end(), none.background);
  const auto mask = covered_mask(s.run(none)[0], bg);
  ResampleOptions off = opts(Filter::Bilinear, GutterFill::PullPush);
  off.fill_blocks = false;
  ResampleOptions on = off;
  on.fill_blocks = true;
  const Image a = s.run(off)[0], b = s.run(on)[0];
  int empty_blocks = 0, partial_blocks = 0, flat_without = 0;
  for (int by = 0; by < 32; by += 8)
    for (int bx = 0; bx < 32; bx += 8) {
      int lo[3] = {255, 255, 255}, hi[3] = {0, 0, 0}, n = 0;
      for (int y = by; y < by + 8; ++y)
        for (int x = bx; x < bx + 8; ++x) {
          if (!mask[static_cast<size_t>(y * 32 + x)]) continue;
          ++n;
          EXPECT_TRUE(same_texel(a, x, y, b, x, y)) << "written texel " << x << "," << y;
          for (int ch = 0; ch < 3; ++ch) {
            lo[ch] = std::min<int>(lo[ch], b.at(x, y)[ch]);
            hi[ch] = std::max<int>(hi[ch], b.at(x, y)[ch]);
          }
        }
      bool flat_a = true;
      for (int y = by; y < by + 8; ++y)
        for (int x = bx; x < bx + 8; ++x) {
          if (mask[static_cast<size_t>(y * 32 + x)]) continue;
          flat_a = flat_a && same_texel(a, x, y, a, bx, by);
          if (n == 0) {
            EXPECT_TRUE(same_texel(b, x, y, b, bx, by)) << "empty block texel " << x << "," << y;
          }
          for (int ch = 0; n > 0 && ch < 3; ++ch) {  // harmonic: within the written texels' range
            EXPECT_GE(b.at(x, y)[ch], lo[ch]) << x << "," << y;
            EXPECT_LE(b.at(x, y)[ch], hi[ch]) << x << "," << y;
          }
        }
      empty_blocks += n == 0;
      partial_blocks += n > 0 && n < 64;
      flat_without += n == 0 && flat_a;
    }
  EXPECT_GE(empty_blocks, 3);
  EXPECT_GE(partial_blocks, 6);
  EXPECT_EQ(flat_without, 0);  // pull-push alone leaves gradients in the empty blocks
  // What it is for: the page costs fewer JPEG bytes.
  EXPECT_LT(encode_jpeg(b, 90, JpegSubsampling::S444, "on").size(), encode_jpeg(a, 90, JpegSubsampling::S444, "off").size());
}

TEST(TextureResample, DilateRespectsWidth) {
  const Image img = make_image(16, 16, 3, [](int, int, int ch) { return 60 + 30 * ch; });
  Scene s;
  const int in = s.add_input_page(img);
  s.add_rect(s.add_chart(in, s.add_output_page(24, 24)), 2, 2, 6, 5, [](const Vec2& p) -> Vec2 { return p + Vec2(8, 9); });
  const std::array<uint8_t, 4> bg{255, 0, 255, 255};
  ResampleOptions none = opts(Filter::Bilinear, GutterFill::None);
  std::copy(bg.begin(), bg.end(), none.background);
  const auto mask = covered_mask(s.run(none)[0], bg);
  for (int width : {0, 1, 3}) {
    ResampleOptions o = opts(Filter::Bilinear, GutterFill::Dilate);
    o.dilate_width = width;
    std::copy(bg.begin(), bg.end(), o.background);
    const auto pages = s.run(o);
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 24; ++x) {
        int d = 1000;  // Chebyshev distance to the covered set
        for (int v = 0; v < 24; ++v)
          for (int u = 0; u < 24; ++u)
            if (mask[static_cast<size_t>(v * 24 + u)]) d = std::min(d, std::max(std::abs(u - x), std::abs(v - y)));
        const uint8_t* p = pages[0].at(x, y);
        if (d <= width) {
          EXPECT_EQ(p[0], 60) << width << ": " << x << "," << y;
          EXPECT_EQ(p[2], 120) << width << ": " << x << "," << y;
        } else {
          EXPECT_TRUE(std::equal(p, p + 3, bg.begin())) << width << ": " << x << "," << y;
        }
      }
  }
}

TEST(TextureResample, InteriorWinsOverBorder) {
  // Left half of the input red, right half blue. Two charts meet at x = 4 on the output page; the
  // border of each reaches one texel into the other's interior and extrapolates its own colour
  // there. The interior must win in both drawing orders.
  const Image img = make_image(8, 8, 3, [](int x, int, int c) { return x < 4 ? (c == 0 ? 200 : 0) : (c == 2 ? 200 : 0); });
  for (int order = 0; order < 2; ++order) {
    Scene s;
    const int in = s.add_input_page(img);
    const int out = s.add_output_page(8, 8);
    const int red = s.add_chart(in, out), blue = s.add_chart(in, out);
    // red input [0,2] -> output [2,4]; blue input [6,8] -> output [4,6] (full height)
    const auto add_red = [&] { s.add_rect(red, 0, 0, 2, 8, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 2, p.y()); }); };
    const auto add_blue = [&] { s.add_rect(blue, 6, 0, 8, 8, [](const Vec2& p) -> Vec2 { return Vec2(p.x() - 2, p.y()); }); };
    if (order == 0) { add_red(); add_blue(); } else { add_blue(); add_red(); }
    const auto pages = s.run(opts(Filter::Nearest, GutterFill::None));
    for (int j = 0; j < 8; ++j) {
      for (int i : {1, 2, 3}) EXPECT_EQ(pages[0].at(i, j)[0], 200) << order << " red " << i << "," << j;
      for (int i : {4, 5, 6}) EXPECT_EQ(pages[0].at(i, j)[2], 200) << order << " blue " << i << "," << j;
    }
  }
  // Between two charts, a texel in both borders goes to the nearer triangle whatever the order:
  // red output [1, 3.2], blue output [4, 6]; texel column 3 (centre 3.5) is 0.3 from red and 0.5
  // from blue.
  for (int order = 0; order < 2; ++order) {
    Scene s;
    const int in = s.add_input_page(img);
    const int out = s.add_output_page(8, 8);
    const int red = s.add_chart(in, out), blue = s.add_chart(in, out);
    const auto add_red = [&] { s.add_rect(red, 0, 0, 2.2, 8, [](const Vec2& p) -> Vec2 { return Vec2(p.x() + 1, p.y()); }); };
    const auto add_blue = [&] { s.add_rect(blue, 5, 0, 7, 8, [](const Vec2& p) -> Vec2 { return Vec2(p.x() - 1, p.y()); }); };
    if (order == 0) { add_red(); add_blue(); } else { add_blue(); add_red(); }
    const auto pages = s.run(opts(Filter::Nearest, GutterFill::None));
    for (int j = 0; j < 8; ++j) EXPECT_EQ(pages[0].at(3, j)[0], 200) << order << " row " << j;
  }
}

TEST(TextureResample, DegenerateTrianglesGiveFiniteColours) {
  const Image img = pattern(8, 8, 3);
  // (a) zero-area output (all corners at (4, 4)): the four texels whose centres are within one
  // texel take the colour at the input centroid (2.5, 5.5) = centre of input texel (2, 2).
  {
    Scene s;
    const int in = s.add_input_page(img);
    s.add_face(s.add_chart(in, s.add_output_page(8, 8)), {Vec2(1.5, 4.5), Vec2(3.5, 5.5), Vec2(2.5, 6.5)},
               {Vec2(4, 4), Vec2(4, 4), Vec2(4, 4)});
    ResampleStats st;
    const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None), &st);
    EXPECT_EQ(st.texels_written, 4u);
    EXPECT_EQ(st.faces_resampled, 1u);
    for (int j : {3, 4})
      for (int i : {3, 4}) EXPECT_TRUE(same_texel(pages[0], i, j, img, 2, 2)) << i << "," << j;
  }
  // (b) collinear output corners: texels along the segment get colour, no crash.
  {
    Scene s;
    const int in = s.add_input_page(img);
    s.add_face(s.add_chart(in, s.add_output_page(8, 8)), {Vec2(1, 1), Vec2(5, 1), Vec2(1, 5)},
               {Vec2(1, 1), Vec2(4, 4), Vec2(7, 7)});
    ResampleStats st;
    const auto pages = s.run(opts(Filter::Bicubic, GutterFill::PullPush), &st);
    EXPECT_GT(st.texels_written, 6u);
    EXPECT_EQ(st.faces_copied, 0u);
  }
  // (c) zero-area input (a point at the centre of input texel (5, 1)) on a proper output triangle:
  // every covered texel is that texel's colour.
  {
    Scene s;
    const int in = s.add_input_page(img);
    const Vec2 p(5.5, 6.5);
    s.add_face(s.add_chart(in, s.add_output_page(8, 8)), {p, p, p}, {Vec2(1, 1), Vec2(7, 1), Vec2(1, 7)});
    ResampleStats st;
    const std::array<uint8_t, 4> bg{255, 0, 255, 255};
    ResampleOptions o = opts(Filter::Bicubic, GutterFill::None);
    std::copy(bg.begin(), bg.end(), o.background);
    const auto pages = s.run(o, &st);
    EXPECT_GT(st.texels_written, 20u);
    const auto mask = covered_mask(pages[0], bg);
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x)
        if (mask[static_cast<size_t>(y * 8 + x)]) {
          EXPECT_TRUE(same_texel(pages[0], x, y, img, 5, 1)) << x << "," << y;
        }
  }
  // (d) a near-sliver output (stretch far above 4): border texels use the nearest point of the
  // triangle, so their colours come from the input triangle's neighbourhood.
  {
    const Image flat = make_image(16, 16, 1, [](int x, int, int) { return x < 8 ? 50 : 250; });
    Scene s;
    const int in = s.add_input_page(flat);
    s.add_face(s.add_chart(in, s.add_output_page(16, 16)), {Vec2(1, 1), Vec2(6, 1), Vec2(1, 6)},
               {Vec2(2, 2), Vec2(12, 2), Vec2(7, 2.001)});
    const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None));
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) EXPECT_NE(pages[0].at(x, y)[0], 250) << x << "," << y;
  }
}

TEST(TextureResample, RandomTrianglesOnAConstantPageGiveTheConstant) {
  // Any sample of a constant page is that constant, whatever the triangle: random, off-page,
  // collinear, point-like and sliver triangles, every filter and fill, all over a 32x32 page.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> coord(-20.0, 52.0);
  std::uniform_int_distribution<int> kind(0, 5);
  Scene s;
  const int in = s.add_input_page(make_image(16, 16, 3, [](int, int, int c) { return 30 + 70 * c; }));
  const int out = s.add_output_page(32, 32);
  for (int n = 0; n < 300; ++n) {
    const int c = s.add_chart(in, out);
    Tri a{Vec2(coord(rng) / 4 + 4, coord(rng) / 4 + 4), Vec2(coord(rng) / 4 + 4, coord(rng) / 4 + 4), Vec2(coord(rng) / 4 + 4, coord(rng) / 4 + 4)};
    Tri b{Vec2(coord(rng), coord(rng)), Vec2(coord(rng), coord(rng)), Vec2(coord(rng), coord(rng))};
    switch (kind(rng)) {
      case 0: b[2] = b[0] + 0.5 * (b[1] - b[0]); break;         // collinear output
      case 1: b[1] = b[2] = b[0]; break;                         // point output
      case 2: a[1] = a[2] = a[0]; break;                         // point input
      case 3: b[2] = b[0] + (b[1] - b[0]) * 0.3 + Vec2(1e-7, 0); break;  // sliver
      default: break;
    }
    s.add_face(c, a, b);
  }
  for (Filter f : {Filter::Nearest, Filter::Bilinear, Filter::Bicubic})
    for (GutterFill g : {GutterFill::None, GutterFill::Dilate, GutterFill::PullPush}) {
      ResampleOptions o = opts(f, g);
      const std::array<uint8_t, 4> bg{255, 0, 255, 255};
      std::copy(bg.begin(), bg.end(), o.background);
      ResampleStats st;
      const auto pages = s.run(o, &st);
      ASSERT_EQ(pages.size(), 1u);
      EXPECT_EQ(st.faces_copied + st.faces_resampled, 300u);
      EXPECT_GT(st.texels_written, 100u);
      for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
          const uint8_t* p = pages[0].at(x, y);
          const bool is_bg = std::equal(p, p + 3, bg.begin());
          EXPECT_TRUE(g != GutterFill::PullPush || !is_bg) << x << "," << y;
          if (!is_bg) {
            ASSERT_EQ(p[0], 30) << x << "," << y;
            ASSERT_EQ(p[1], 100) << x << "," << y;
            ASSERT_EQ(p[2], 170) << x << "," << y;
          }
        }
    }
}

TEST(TextureResample, MixedChannelCountsPromote) {
  // A grey page and an RGBA page: output has 4 channels; grey is replicated, alpha 255.
  Scene s;
  const int g = s.add_input_page(make_image(4, 4, 1, [](int, int, int) { return 77; }));
  const int rgba = s.add_input_page(make_image(4, 4, 4, [](int, int, int c) { return 10 + c; }));
  const int out = s.add_output_page(8, 4);
  s.add_rect(s.add_chart(g, out), 0, 0, 4, 4, [](const Vec2& p) -> Vec2 { return p; });
  s.add_rect(s.add_chart(rgba, out), 0, 0, 4, 4, [](const Vec2& p) -> Vec2 { return p + Vec2(4, 0); });
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::None));
  ASSERT_EQ(pages[0].channels, 4);
  const uint8_t grey[4] = {77, 77, 77, 255}, col[4] = {10, 11, 12, 13};
  EXPECT_TRUE(std::equal(grey, grey + 4, pages[0].at(1, 1)));
  EXPECT_TRUE(std::equal(col, col + 4, pages[0].at(6, 2)));
}

TEST(TextureResample, ProgressAndCancel) {
  Scene s;
  const int in = s.add_input_page(pattern(16, 16));
  for (int p = 0; p < 3; ++p) s.add_rect(s.add_chart(in, s.add_output_page(16, 16)), 1, 1, 15, 15, [](const Vec2& q) -> Vec2 { return q; });
  std::vector<double> seen;
  s.run(opts(Filter::Bilinear, GutterFill::PullPush), nullptr, [&](const std::string& stage, double f) {
    EXPECT_EQ(stage, "texture.resample");
    seen.push_back(f);
    return true;
  });
  ASSERT_GE(seen.size(), 2u);
  EXPECT_EQ(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_THROW(s.run(opts(Filter::Bilinear, GutterFill::PullPush), nullptr, [](const std::string&, double) { return false; }),
               Cancelled);
}

TEST(TextureResample, BadInputIsAClearError) {
  Scene s;
  const int in = s.add_input_page(pattern(8, 8));
  s.add_rect(s.add_chart(in, s.add_output_page(8, 8)), 0, 0, 8, 8, [](const Vec2& p) -> Vec2 { return p; });
  const auto expect_error = [](const Scene& bad, const std::string& fragment) {
    try {
      bad.run(opts(Filter::Bilinear, GutterFill::PullPush));
      ADD_FAILURE() << "no error for " << fragment;
    } catch (const StageError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("texture.resample: ", 0), 0u) << e.what();
    }
  };
  Scene a = s;
  a.inputs.clear();
  expect_error(a, "input page images");
  Scene b = s;
  b.inputs[0] = pattern(4, 8);
  expect_error(b, "mesh page says 8x8");
  Scene c = s;
  c.layout.wedge_uv[1].x() = std::nan("");
  expect_error(c, "output UV is not finite");
  Scene d = s;
  d.layout.pages[0].width = 0;
  expect_error(d, "output page 0 has size 0x8");
  Scene e = s;
  e.layout.chart_page.clear();
  expect_error(e, "no output page");
  ResampleOptions o = opts(Filter::Bilinear, GutterFill::Dilate);
  o.dilate_width = -1;
  EXPECT_THROW(s.run(o), StageError);
}

// ------------------------------------------------------------------------------------------------
// Least-squares texel fit

/// Bilinear value (no rounding) of channel c at texel-space point p (y up), clamp-to-edge, as eval's
/// fidelity measure reads pages.
double read_bilinear(const Image& im, const Vec2& p, int c) {
  const double gx = std::min(std::max(p.x() - 0.5, 0.0), im.width - 1.0);
  const double gy = std::min(std::max(im.height - p.y() - 0.5, 0.0), im.height - 1.0);
  const int x0 = static_cast<int>(gx), y0 = static_cast<int>(gy);
  const int x1 = std::min(x0 + 1, im.width - 1), y1 = std::min(y0 + 1, im.height - 1);
  const double fx = gx - x0, fy = gy - y0;
  const double top = im.at(x0, y0)[c] + fx * (im.at(x1, y0)[c] - im.at(x0, y0)[c]);
  const double bot = im.at(x0, y1)[c] + fx * (im.at(x1, y1)[c] - im.at(x0, y1)[c]);
  return top + fy * (bot - top);
}

/// PSNR (dB) of the output read bilinearly at map(p) against the input read bilinearly at p, over a
/// regular grid of points p in the input rectangle [x0, x1]^2 shrunk by `inset`.
double rect_psnr(const Image& in, const Image& out, double x0, double x1, double inset,
                 const std::function<Vec2(const Vec2&)>& map) {
  double se = 0;
  size_t n = 0;
  for (double y = x0 + inset; y <= x1 - inset; y += 0.173)
    for (double x = x0 + inset; x <= x1 - inset; x += 0.173) {
      const Vec2 p(x, y), q = map(p);
      for (int c = 0; c < in.channels; ++c) {
        const double d = read_bilinear(in, p, c) - read_bilinear(out, q, c);
        se += d * d;
        ++n;
      }
    }
  return 10 * std::log10(255.0 * 255.0 / (se / static_cast<double>(n)));
}

/// Photo-like content: smooth shading, edges and texel-level noise (deterministic).
Image photo_like(int w, int h) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> noise(-24, 24);
  return make_image(w, h, 3, [&](int x, int y, int c) {
    const double v = 120 + 60 * std::sin(0.21 * x + 0.05 * c) * std::cos(0.13 * y) + ((x / 5 + y / 7) % 2 ? 30 : -30) +
                     noise(rng);
    return static_cast<int>(std::min(255.0, std::max(0.0, v)));
  });
}

ResampleOptions fit_opts(TexelFit fit) {
  ResampleOptions o = opts(Filter::Bilinear, GutterFill::PullPush);
  o.fit = fit;
  return o;
}

TEST(TextureResample, LeastSquaresFitBeatsSamplingOnRotatedCharts) {
  // A 48x48-texel square turned by various angles: the output read bilinearly is closer to the input
  // read bilinearly with the fit than with plain sampling (which filters twice), by at least 1 dB.
  const Image img = photo_like(64, 64);
  // The square turned by `rad` about its centre, which lands at `centre` of a `side`^2 page.
  auto compare = [&img](const char* what, double rad, const Vec2& centre, int side) {
    const auto map = [rad, centre](const Vec2& p) -> Vec2 {
      const Vec2 d = p - Vec2(32, 32);
      return centre + Vec2(std::cos(rad) * d.x() - std::sin(rad) * d.y(), std::sin(rad) * d.x() + std::cos(rad) * d.y());
    };
    double psnr[2];
    for (int k = 0; k < 2; ++k) {
      Scene s;
      const int in = s.add_input_page(img);
      s.add_rect(s.add_chart(in, s.add_output_page(side, side)), 8, 8, 56, 56, map);
      ResampleStats st;
      const auto pages = s.run(fit_opts(k ? TexelFit::LeastSquares : TexelFit::Sample), &st);
      EXPECT_EQ(st.texels_fitted > 0, k == 1);
      psnr[k] = rect_psnr(img, pages[0], 8, 56, 0.0, map);
    }
    std::printf("  %s: sample %.2f dB, least squares %.2f dB\n", what, psnr[0], psnr[1]);
    EXPECT_GT(psnr[1], psnr[0] + 1.0) << what;
  };
  compare("rotation 10 deg", 10 * 3.141592653589793 / 180, Vec2(48.3, 47.6), 96);
  compare("rotation 30 deg", 30 * 3.141592653589793 / 180, Vec2(48.3, 47.6), 96);
  compare("rotation 45 deg", 45 * 3.141592653589793 / 180, Vec2(48.3, 47.6), 96);
  // Pages are fitted in windows of 256 texels: a chart across window borders gains as much.
  compare("across a fit window border", 0.5, Vec2(1024.3, 1030.6), 1100);
}

TEST(TextureResample, LeastSquaresFitIsTheSameForAnyThreadCount) {
  // A page of 13 x 9 fit windows (windows solved side by side as their neighbours are done, and
  // prepared ahead) with charts across window borders and corners: the texels are identical with 1,
  // 2, 3 and 4 threads (docs/framework.md, "Threads").
  const Image img = photo_like(64, 64);
  Scene s;
  const int in = s.add_input_page(img);
  const int out = s.add_output_page(3200, 2200);
  const Vec2 centres[] = {{1024.3, 1030.6}, {2048.7, 1023.2}, {3070.1, 40.9}, {40.5, 2100.2}, {1500.5, 1500.5}, {2047.9, 2048.1}};
  double rad = 0.3;
  for (const Vec2& c : centres) {
    const auto map = [rad, c](const Vec2& p) -> Vec2 {
      const Vec2 d = p - Vec2(32, 32);
      return c + Vec2(std::cos(rad) * d.x() - std::sin(rad) * d.y(), std::sin(rad) * d.x() + std::cos(rad) * d.y());
    };
    s.add_rect(s.add_chart(in, out), 8, 8, 56, 56, map);
    rad += 0.4;
  }
  std::vector<Image> pages[4];
  const int threads[] = {1, 2, 3, 4};
  for (int k = 0; k < 4; ++k) {
    set_thread_count(threads[k]);
    ResampleStats st;
    pages[k] = s.run(fit_opts(TexelFit::LeastSquares), &st);
    EXPECT_GT(st.texels_fitted, 6000u);
  }
  set_thread_count(0);
  EXPECT_TRUE(pages[0][0].pixels == pages[1][0].pixels);
  EXPECT_TRUE(pages[0][0].pixels == pages[2][0].pixels);
  EXPECT_TRUE(pages[0][0].pixels == pages[3][0].pixels);
}

TEST(TextureResample, LeastSquaresFitKeepsLinearRampsAndCopiedTexels) {
  // A linear ramp is represented exactly by the bilinear basis: the fit keeps it (within rounding).
  const Image ramp = make_image(64, 64, 1, [](int x, int y, int) { return 2 * x + y; });
  const auto map = [](const Vec2& p) -> Vec2 {
    const double a = 0.4;
    const Vec2 d = p - Vec2(32, 32);
    return Vec2(40.25 + std::cos(a) * d.x() - std::sin(a) * d.y(), 40.5 + std::sin(a) * d.x() + std::cos(a) * d.y());
  };
  Scene s;
  const int in = s.add_input_page(ramp);
  const int out = s.add_output_page(80, 80);
  s.add_rect(s.add_chart(in, out), 16, 16, 48, 48, map);
  const auto pages = s.run(fit_opts(TexelFit::LeastSquares));
  for (double y = 20; y <= 44; y += 1.7)
    for (double x = 20; x <= 44; x += 1.3) {
      const Vec2 q = map(Vec2(x, y));
      EXPECT_NEAR(read_bilinear(pages[0], q, 0), read_bilinear(ramp, Vec2(x, y), 0), 1.0) << x << "," << y;
    }
  // Whole-texel moves stay bit-exact copies: nothing to fit.
  Scene c;
  const int cin = c.add_input_page(pattern(16, 16));
  c.add_rect(c.add_chart(cin, c.add_output_page(16, 16)), 2, 2, 14, 14, [](const Vec2& p) -> Vec2 { return p; });
  ResampleStats st;
  const auto cp = c.run(fit_opts(TexelFit::LeastSquares), &st);
  EXPECT_EQ(st.texels_fitted, 0u);
  for (int y = 3; y < 13; ++y)
    for (int x = 3; x < 13; ++x) EXPECT_TRUE(same_texel(cp[0], x, y, c.inputs[0], x, y)) << x << "," << y;
}

TEST(TextureResample, LeastSquaresFitIterationsAreValidated) {
  Scene s;
  const int in = s.add_input_page(pattern(8, 8));
  s.add_rect(s.add_chart(in, s.add_output_page(8, 8)), 1, 1, 6, 6, [](const Vec2& p) -> Vec2 { return p + Vec2(0.3, 0); });
  ResampleOptions o = fit_opts(TexelFit::LeastSquares);
  o.fit_iterations = 0;
  EXPECT_THROW(s.run(o), StageError);
}

// ------------------------------------------------------------------------------------------------
// Texture addressing (issue 11, case 3): repeat as the MTL default says, clamp with `-clamp on`.

/// 33 x 31 = 1,023 texels, each its own colour.
Image distinct_colours() {
  return make_image(33, 31, 3, [](int x, int y, int c) { return c == 0 ? x * 7 : c == 1 ? y * 8 : (x * 5 + y * 3) % 256; });
}

/// Bilinear value (no rounding) of channel c at texel-space point p (y up) with repeat addressing.
double read_bilinear_repeat(const Image& im, const Vec2& p, int c) {
  const double gx = p.x() - 0.5, gy = im.height - p.y() - 0.5;
  const int x0 = static_cast<int>(std::floor(gx)), y0 = static_cast<int>(std::floor(gy));
  const auto wrap = [](int v, int n) { return ((v % n) + n) % n; };
  const int xa = wrap(x0, im.width), xb = wrap(x0 + 1, im.width), ya = wrap(y0, im.height), yb = wrap(y0 + 1, im.height);
  const double fx = gx - x0, fy = gy - y0;
  const double top = im.at(xa, ya)[c] + fx * (im.at(xb, ya)[c] - im.at(xa, ya)[c]);
  const double bot = im.at(xa, yb)[c] + fx * (im.at(xb, yb)[c] - im.at(xa, yb)[c]);
  return top + fy * (bot - top);
}

TEST(TextureResampleAddressing, AChartFarOutsideTheUnitSquareKeepsItsColours) {
  // The whole page as a chart at u = 37..38 (a whole-texel translation: copied), repeat addressing.
  Scene s;
  const Image img = distinct_colours();
  const int in = s.add_input_page(img);
  const int c = s.add_chart(in, s.add_output_page(33, 31));
  s.add_rect(c, 37 * 33, 0, 38 * 33, 31, [](const Vec2& p) -> Vec2 { return Vec2(p.x() - 37 * 33, p.y()); });
  for (const Filter f : {Filter::Nearest, Filter::Bilinear, Filter::Bicubic}) {
    const auto pages = s.run(opts(f, GutterFill::PullPush));
    EXPECT_EQ(pages[0].pixels, img.pixels) << "filter " << static_cast<int>(f);
  }
}

TEST(TextureResampleAddressing, AChartSpanningThePageBorderWrapsWhenResampled) {
  // u from -1 to 2 (three periods) and v from -0.5 to 0.5, scaled by 1.37 on the output page: every
  // output texel reads the input through its wrap.
  Scene s;
  const Image img = distinct_colours();
  const int in = s.add_input_page(img);
  const double k = 1.37;
  const int ow = static_cast<int>(std::ceil(3 * 33 * k)) + 2, oh = static_cast<int>(std::ceil(31 * k)) + 2;
  const int c = s.add_chart(in, s.add_output_page(ow, oh));
  const auto map = [&](const Vec2& p) -> Vec2 { return Vec2((p.x() + 33) * k + 1, (p.y() + 15.5) * k + 1); };
  s.add_rect(c, -33, -15.5, 66, 15.5, map);
  for (const TexelFit fit : {TexelFit::Sample, TexelFit::LeastSquares}) {
    ResampleOptions o = opts(Filter::Bilinear, GutterFill::PullPush);
    o.fit = fit;
    const auto pages = s.run(o);
    double se = 0;
    size_t n = 0;
    for (double y = -15; y <= 15; y += 0.173)
      for (double x = -32.5; x <= 65.5; x += 0.173) {
        const Vec2 p(x, y), q = map(p);
        for (int ch = 0; ch < 3; ++ch) {
          const double d = read_bilinear_repeat(img, p, ch) - read_bilinear(pages[0], q, ch);
          se += d * d;
          ++n;
        }
      }
    const double psnr = 10 * std::log10(255.0 * 255.0 / (se / static_cast<double>(n)));
    EXPECT_GT(psnr, 30.0) << "fit " << static_cast<int>(fit);
  }
}

TEST(TextureResampleAddressing, ClampOnClampsToTheEdge) {
  // `map_Kd -clamp on`: the chart at u = 37..38 reads the page's right column everywhere.
  Scene s;
  const Image img = distinct_colours();
  const int in = s.add_input_page(img);
  s.mesh.pages[0].clamp = true;
  const int c = s.add_chart(in, s.add_output_page(33, 31));
  s.add_rect(c, 37 * 33, 0, 38 * 33, 31, [](const Vec2& p) -> Vec2 { return Vec2(p.x() - 37 * 33, p.y()); });
  const auto pages = s.run(opts(Filter::Bilinear, GutterFill::PullPush));
  for (int j = 0; j < 31; ++j)
    for (int i = 0; i < 33; ++i) EXPECT_TRUE(same_texel(pages[0], i, j, img, 32, j)) << i << "," << j;
}

}  // namespace
}  // namespace texdefrag
