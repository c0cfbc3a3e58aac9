// Appearance measures (appearance.h) on hand-built cases whose answers are known by hand: a
// two-chart page's texel clashes per MIP level, a seam with a known colour jump, identical pairs
// with infinite PSNR and SSIM 1; and the whole comparison on a real tile when present.
#include "texdefrag/eval/appearance.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace texdefrag;
using namespace texdefrag::eval;
namespace fx = texdefrag::testing;

namespace {

Image solid(int w, int h, uint8_t r, uint8_t g, uint8_t b) {
  Image im;
  im.width = w, im.height = h, im.channels = 3;
  im.pixels.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
  for (size_t i = 0; i < im.pixels.size(); i += 3) im.pixels[i] = r, im.pixels[i + 1] = g, im.pixels[i + 2] = b;
  return im;
}

Image noise(int w, int h, unsigned seed) {
  Image im = solid(w, h, 0, 0, 0);
  std::mt19937 rng(seed);
  for (uint8_t& v : im.pixels) v = static_cast<uint8_t>(rng() & 255u);
  return im;
}

/// Adds a quad (two triangles, separate 3D vertices) whose UVs are the texel rectangle
/// [x0, x1] x [y0, y1] of a page of `size` texels, on page `page`.
void add_uv_rect(TexturedMesh& m, double x0, double x1, double y0, double y1, int size, int page, double z) {
  const int v = static_cast<int>(m.positions.size()), t = static_cast<int>(m.texcoords.size());
  const double s = size;
  for (auto [x, y] : {std::pair{x0, y0}, std::pair{x1, y0}, std::pair{x1, y1}, std::pair{x0, y1}}) {
    m.positions.emplace_back(x, y, z);
    m.texcoords.emplace_back(x / s, y / s);
  }
  for (std::array<int, 3> c : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
    Face f;
    for (int k = 0; k < 3; ++k) f.v[static_cast<size_t>(k)] = v + c[static_cast<size_t>(k)], f.vt[static_cast<size_t>(k)] = t + c[static_cast<size_t>(k)];
    f.material = page, f.page = page;
    m.faces.push_back(f);
  }
}

TexturedMesh one_page_mesh(int size, int pages = 1) {
  TexturedMesh m;
  for (int p = 0; p < pages; ++p) {
    m.materials.push_back({"m" + std::to_string(p), {}, "p" + std::to_string(p) + ".png", ""});
    m.pages.push_back({"m" + std::to_string(p), "p" + std::to_string(p) + ".png", size, size});
  }
  return m;
}

}  // namespace

TEST(Images, MipPyramidBoxFilterAndOddSizes) {
  Image im = solid(3, 3, 0, 0, 0);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x) im.at(x, y)[0] = static_cast<uint8_t>(10 * (y * 3 + x));
  const std::vector<Image> p = mip_pyramid(im, 8);
  ASSERT_EQ(p.size(), 3u);  // 3x3, 2x2, 1x1
  EXPECT_EQ(p[1].width, 2);
  EXPECT_EQ(p[1].at(0, 0)[0], 20);  // (0 + 10 + 30 + 40) / 4
  EXPECT_EQ(p[1].at(1, 0)[0], 35);  // (20 + 50) / 2
  EXPECT_EQ(p[1].at(1, 1)[0], 80);  // the corner texel alone
  EXPECT_EQ(mip_pyramid(im, 1).size(), 2u);
}

TEST(Images, PsnrAndSsimByHand) {
  const Image a = noise(40, 30, 1);
  Image b = a;
  std::vector<uint8_t> mask(40 * 30, 1);
  EXPECT_TRUE(std::isinf(psnr(a, b, mask)));
  EXPECT_EQ(ssim(a, b, mask), 1.0);
  const Image c = solid(40, 30, 100, 100, 100), d = solid(40, 30, 110, 110, 110);
  EXPECT_NEAR(psnr(c, d, mask), 20 * std::log10(255.0 / 10), 1e-12);
  EXPECT_LT(ssim(a, noise(40, 30, 2), mask), 0.2);
  // Masked-out pixels do not count.
  b.pixels[0] ^= 0xff;
  mask[0] = 0;
  EXPECT_TRUE(std::isinf(psnr(a, b, mask)));
  EXPECT_TRUE(std::isnan(psnr(a, b, std::vector<uint8_t>(40 * 30, 0))));
  EXPECT_THROW(psnr(a, solid(4, 4, 0, 0, 0), mask), std::invalid_argument);
}

// An 8x8 page: chart A covers texel columns 0-2, chart B columns 5-7, columns 3-4 are gutter.
// Level 0: 48 used texels, no clash. Level 1 (4x4): column blocks {2,3} (A + gutter) and {4,5}
// (gutter + B) clash on all 4 rows: 8 of 16. Level 2 (2x2): both column blocks mix: 4 of 4.
// Level 3: the single texel mixes everything: 1 of 1.
TEST(TexelClashes, TwoChartPageByHand) {
  TexturedMesh m = one_page_mesh(8);
  add_uv_rect(m, 0, 3, 0, 8, 8, 0, 0.0);
  add_uv_rect(m, 5, 8, 0, 8, 8, 0, 1.0);
  const std::vector<ClashLevel> c = texel_clashes(m, 4);
  ASSERT_EQ(c.size(), 5u);
  const size_t texels[] = {64, 16, 4, 1, 1}, used[] = {48, 16, 4, 1, 1}, clashes[] = {0, 8, 4, 1, 1};
  for (size_t l = 0; l < 5; ++l) {
    EXPECT_EQ(c[l].level, static_cast<int>(l));
    EXPECT_EQ(c[l].texels, texels[l]) << "level " << l;
    EXPECT_EQ(c[l].used, used[l]) << "level " << l;
    EXPECT_EQ(c[l].clashes, clashes[l]) << "level " << l;
  }
  EXPECT_DOUBLE_EQ(c[1].fraction, 0.5);
}

// One chart filling the page never clashes; two charts overlapping on 2 columns clash at level 0
// on exactly those 16 texels.
TEST(TexelClashes, FullChartAndOverlapByHand) {
  TexturedMesh full = one_page_mesh(8);
  add_uv_rect(full, 0, 8, 0, 8, 8, 0, 0.0);
  for (const ClashLevel& l : texel_clashes(full, 3)) EXPECT_EQ(l.clashes, 0u) << "level " << l.level;
  TexturedMesh over = one_page_mesh(8);
  add_uv_rect(over, 0, 5, 0, 8, 8, 0, 0.0);
  add_uv_rect(over, 3, 8, 0, 8, 8, 0, 1.0);
  const std::vector<ClashLevel> c = texel_clashes(over, 0);
  EXPECT_EQ(c[0].used, 64u);
  EXPECT_EQ(c[0].clashes, 16u);
  EXPECT_THROW(texel_clashes(over, -1), std::invalid_argument);
}

namespace {

/// Two triangles sharing the 3D edge (1,0,0)-(0,1,0); face 0 on page 0, face 1 on page 1, each
/// with its own UVs (so the edge is a seam). `shared_uv`: both on page 0 with shared texcoords.
TexturedMesh seam_pair(bool shared_uv) {
  TexturedMesh m = one_page_mesh(16, 2);
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 0)};
  m.texcoords = {Vec2(0.1, 0.1), Vec2(0.9, 0.1), Vec2(0.1, 0.9), Vec2(0.9, 0.9), Vec2(0.2, 0.2), Vec2(0.3, 0.8)};
  Face a, b;
  a.v = {0, 1, 2}, a.vt = {0, 1, 2}, a.page = a.material = 0;
  b.v = {1, 3, 2};
  b.vt = shared_uv ? std::array<int, 3>{1, 3, 2} : std::array<int, 3>{4, 5, 3};
  b.page = b.material = shared_uv ? 0 : 1;
  m.faces = {a, b};
  return m;
}

}  // namespace

TEST(SeamColour, KnownJumpAcrossOneSeam) {
  const TexturedMesh m = seam_pair(false);
  const SeamColourMetrics s = seam_colour(m, {solid(16, 16, 100, 50, 0), solid(16, 16, 103, 54, 0)});
  EXPECT_EQ(s.seam_edges, 1u);
  EXPECT_NEAR(s.length_3d, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s.mean, 5.0, 1e-9);  // |(3, 4, 0)|
  EXPECT_NEAR(s.rms, 5.0, 1e-9);
  EXPECT_NEAR(s.max, 5.0, 1e-9);
  EXPECT_GE(s.samples, 1u);
  // Solid pages: the same jump at every MIP level.
  for (const SeamColourLevel& l : seam_colour(m, {solid(16, 16, 100, 50, 0), solid(16, 16, 103, 54, 0)}, 4).levels)
    EXPECT_NEAR(l.mean, 5.0, 1e-9) << "level " << l.level;
  const SeamColourMetrics same = seam_colour(m, {solid(16, 16, 7, 8, 9), solid(16, 16, 7, 8, 9)});
  EXPECT_EQ(same.seam_edges, 1u);
  EXPECT_EQ(same.mean, 0.0);
  // UV-continuous across the edge: no seam at all.
  const SeamColourMetrics none = seam_colour(seam_pair(true), {solid(16, 16, 0, 0, 0), solid(16, 16, 255, 0, 0)});
  EXPECT_EQ(none.seam_edges, 0u);
  EXPECT_EQ(none.samples, 0u);
  EXPECT_THROW(seam_colour(m, {solid(16, 16, 0, 0, 0)}), std::invalid_argument);
}

// The seam per MIP level, by hand. A 16x16 page: columns 0-11 grey 200, 12-15 black (gutter).
// Two charts share the 3D edge x = 1 (a vertical line on the page in both): chart A's side of it
// lies at u = 11.5 texels, next to the gutter, chart B's at u = 4.5, inside the grey. Rows are
// uniform, so only u matters. Bilinear reads (texel centres at half-integers) of the box-filtered
// levels (widths 16, 8, 4, 2, 1; grey per column):
//   L0: A reads column 11 = 200, B column 4 = 200                  -> 0
//   L1: A at 5.75: 0.75 x 200 + 0.25 x 0 = 150; B at 2.25: 200     -> 50
//   L2: A at 2.875: 0.625 x 200 = 125; B at 1.125: 200             -> 75
//   L3: columns (200, 100); A at 1.4375: 106.25; B at 0.5625: 193.75 -> 87.5
//   L4: one texel, 150 on both sides                              -> 0
// The distance is Euclidean over R, G, B, so each is the grey step times sqrt(3).
TEST(SeamColour, PerMipLevelByHand) {
  TexturedMesh m = one_page_mesh(16);
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), Vec3(2, 0, 0), Vec3(2, 1, 0)};
  const double s = 16;
  m.texcoords = {Vec2(8.5 / s, 0.5 / s), Vec2(11.5 / s, 0.5 / s), Vec2(11.5 / s, 15.5 / s), Vec2(8.5 / s, 15.5 / s),   // A
                 Vec2(4.5 / s, 0.5 / s), Vec2(7.5 / s, 0.5 / s), Vec2(7.5 / s, 15.5 / s), Vec2(4.5 / s, 15.5 / s)};  // B
  const std::array<std::array<int, 6>, 4> faces = {{{0, 1, 2, 0, 1, 2}, {0, 2, 3, 0, 2, 3}, {1, 4, 5, 4, 5, 6}, {1, 5, 2, 4, 6, 7}}};
  for (const auto& q : faces) {
    Face f;
    f.v = {q[0], q[1], q[2]}, f.vt = {q[3], q[4], q[5]}, f.page = f.material = 0;
    m.faces.push_back(f);
  }
  Image page = solid(16, 16, 200, 200, 200);
  for (int y = 0; y < 16; ++y)
    for (int x = 12; x < 16; ++x)
      for (int c = 0; c < 3; ++c) page.pixels[(static_cast<size_t>(y) * 16 + static_cast<size_t>(x)) * 3 + static_cast<size_t>(c)] = 0;
  const SeamColourMetrics r = seam_colour(m, {page}, 5);
  EXPECT_EQ(r.seam_edges, 1u);
  EXPECT_EQ(r.samples, 15u);  // n = ceil(15 texels) points, the same at every level
  ASSERT_EQ(r.levels.size(), 6u);
  const double grey[] = {0, 50, 75, 87.5, 0, 0};  // level 5: past the 1x1 level, read the 1x1 level
  for (int l = 0; l <= 5; ++l) {
    EXPECT_EQ(r.levels[static_cast<size_t>(l)].level, l);
    EXPECT_NEAR(r.levels[static_cast<size_t>(l)].mean, grey[l] * std::sqrt(3.0), 1e-9) << "level " << l;
    EXPECT_NEAR(r.levels[static_cast<size_t>(l)].rms, grey[l] * std::sqrt(3.0), 1e-9) << "level " << l;
    EXPECT_NEAR(r.levels[static_cast<size_t>(l)].max, grey[l] * std::sqrt(3.0), 1e-9) << "level " << l;
  }
  EXPECT_EQ(r.mean, r.levels[0].mean);
  // Level 0 only by default; a negative level is refused.
  EXPECT_EQ(seam_colour(m, {page}).levels.size(), 1u);
  EXPECT_THROW(seam_colour(m, {page}, -1), std::invalid_argument);
}

TEST(RenderedFidelity, IdenticalPairIsInfiniteAndSsimOne) {
  TexturedMesh m = fx::grid_mesh(4, 3, 64, "unused.png");
  const std::vector<Image> pages = {noise(64, 64, 3)};
  RenderFidelityOptions o;
  o.views = 5, o.size = 64, o.max_level = 2;
  const RenderFidelity r = rendered_fidelity(m, pages, m, pages, o);
  ASSERT_EQ(r.levels.size(), 3u);
  for (const RenderLevel& l : r.levels) {
    EXPECT_EQ(l.size, 64 >> l.level);
    EXPECT_GT(l.pixels, 0u);
    EXPECT_TRUE(std::isinf(l.pair_psnr_db)) << "level " << l.level;
    EXPECT_EQ(l.pair_ssim, 1.0) << "level " << l.level;
    EXPECT_EQ(l.input_psnr_db, l.output_psnr_db);
    // The reference is prefiltered (supersampled), the render MIP-mapped: close, not equal.
    EXPECT_TRUE(std::isfinite(l.input_psnr_db)) << "level " << l.level;
  }
}

// A solid page renders as its colour at every distance, so both sides equal the reference.
TEST(RenderedFidelity, SolidPageIsExactAtEveryDistance) {
  TexturedMesh m = fx::grid_mesh(4, 3, 64, "unused.png");
  const std::vector<Image> pages = {solid(64, 64, 90, 140, 200)};
  RenderFidelityOptions o;
  o.views = 3, o.size = 64, o.max_level = 2;
  for (const RenderLevel& l : rendered_fidelity(m, pages, m, pages, o).levels) {
    EXPECT_TRUE(std::isinf(l.input_psnr_db)) << "level " << l.level;
    EXPECT_TRUE(std::isinf(l.output_psnr_db)) << "level " << l.level;
  }
}

// The paper's rendering claim on a case small enough to check by hand: one red chart on a page
// whose gutter is black. Seen from afar, the coarse MIP levels mix the gutter into the chart's
// border texels (colour bleeding), so the input's fidelity falls with distance; the same chart on
// a page padded with its own colour (what a defragmented atlas with fewer, larger charts gets
// nearly everywhere) stays exact.
TEST(RenderedFidelity, GutterBleedingCostsFidelityFromAfar) {
  TexturedMesh m = one_page_mesh(64);
  add_uv_rect(m, 6, 58, 6, 58, 64, 0, 0);
  Image gutter = solid(64, 64, 0, 0, 0);
  for (int y = 6; y < 58; ++y)
    for (int x = 6; x < 58; ++x) gutter.at(x, y)[0] = 220;
  RenderFidelityOptions o;
  o.views = 5, o.size = 128, o.max_level = 3;
  const RenderFidelity r = rendered_fidelity(m, {gutter}, m, {solid(64, 64, 220, 0, 0)}, o);
  for (const RenderLevel& l : r.levels) {
    EXPECT_TRUE(std::isinf(l.output_psnr_db)) << "level " << l.level;
    EXPECT_TRUE(std::isfinite(l.input_psnr_db)) << "level " << l.level;
  }
  EXPECT_GT(r.levels[0].input_psnr_db, r.levels[3].input_psnr_db + 3.0);
  EXPECT_LT(r.levels[3].input_ssim, r.levels[0].input_ssim);
}

TEST(RenderedFidelity, ChangedTextureAndLostFacesCost) {
  TexturedMesh m = fx::grid_mesh(4, 3, 64, "unused.png");
  const std::vector<Image> in_pages = {solid(64, 64, 100, 100, 100)};
  RenderFidelityOptions o;
  o.views = 4, o.size = 64, o.max_level = 1;
  // A uniform shift of 10 levels everywhere: PSNR 20 log10(255 / 10) at every distance.
  const RenderFidelity r = rendered_fidelity(m, in_pages, m, {solid(64, 64, 110, 110, 110)}, o);
  for (const RenderLevel& l : r.levels) {
    EXPECT_NEAR(l.pair_psnr_db, 20 * std::log10(25.5), 1e-9);
    EXPECT_NEAR(l.output_psnr_db, 20 * std::log10(25.5), 1e-9);
  }
  // An output without half of the faces shows background there.
  TexturedMesh half = m;
  half.faces.resize(m.faces.size() / 2);
  const RenderFidelity h = rendered_fidelity(m, in_pages, half, in_pages, o);
  EXPECT_TRUE(std::isfinite(h.levels[0].pair_psnr_db));
  EXPECT_LT(h.levels[0].pair_psnr_db, 20.0);
  EXPECT_LT(h.levels[0].output_psnr_db, 20.0);
}

// Issue 11, case 3 seen by eval: a page is read with the MTL's addressing (repeat unless
// `-clamp on`), as the resampler reads it. The same mesh with every u moved by 37 periods looks
// the same under repeat; read clamped (as the rendered views once did) it was the page's edge
// column smeared over the model.
TEST(RenderedFidelity, PagesAreReadWithTheirAddressing) {
  const TexturedMesh m = fx::grid_mesh(4, 3, 64, "unused.png");
  TexturedMesh shifted = m;
  for (Vec2& t : shifted.texcoords) t.x() += 37;
  const std::vector<Image> pages = {noise(64, 64, 5)};
  RenderFidelityOptions o;
  o.views = 3, o.size = 64, o.max_level = 2;
  const RenderFidelity base = rendered_fidelity(m, pages, m, pages, o);
  const RenderFidelity r = rendered_fidelity(m, pages, shifted, pages, o);
  ASSERT_EQ(r.levels.size(), base.levels.size());
  for (size_t l = 0; l < r.levels.size(); ++l) {
    EXPECT_GT(r.levels[l].pair_psnr_db, 50.0) << "level " << l;
    EXPECT_NEAR(r.levels[l].output_psnr_db, base.levels[l].output_psnr_db, 0.05) << "level " << l;
  }
  TexturedMesh clamped = shifted;
  clamped.pages[0].clamp = true;
  EXPECT_LT(rendered_fidelity(m, pages, clamped, pages, o).levels[0].pair_psnr_db, 20.0);
}

TEST(RenderedFidelity, OptionsOutsideTheirRangesThrow) {
  TexturedMesh m = fx::grid_mesh(2, 2, 16, "unused.png");
  const std::vector<Image> pages = {solid(16, 16, 1, 2, 3)};
  RenderFidelityOptions o;
  o.size = 48, o.max_level = 2;  // 48 / 4 = 12 px < 16
  EXPECT_THROW(rendered_fidelity(m, pages, m, pages, o), std::invalid_argument);
  o.size = 65, o.max_level = 1;  // 65 is not a multiple of 2
  EXPECT_THROW(rendered_fidelity(m, pages, m, pages, o), std::invalid_argument);
  o.size = 64, o.max_level = 2, o.supersample = 0;
  EXPECT_THROW(rendered_fidelity(m, pages, m, pages, o), std::invalid_argument);
}

TEST(Comparison, AppearanceInJsonAndOptional) {
  const std::string dir = fx::temp_dir();
  TexturedMesh m = fx::grid_mesh(3, 2, 32, dir + "/page.png");
  fx::write_test_image(dir + "/page.png", 32, 32);
  EvalOptions o;
  o.fidelity.samples = 2000;
  o.render.size = 64, o.render.views = 2, o.render.max_level = 2, o.clash_max_level = 2;
  const Comparison c = compare(m, m, o);
  const nlohmann::json j = to_json(c);
  ASSERT_EQ(j["texel_clashes"]["input"].size(), 3u);
  EXPECT_EQ(j["texel_clashes"]["input"], j["texel_clashes"]["output"]);
  EXPECT_EQ(j["seam_colour"]["output"]["seam_edges"], 0);
  EXPECT_TRUE(j["rendered"]["levels"][0]["pair_psnr_db"].is_null());  // +infinity
  EXPECT_EQ(j["rendered"]["levels"][2]["pair_ssim"], 1.0);
  EXPECT_NE(summary(c).find("texel clashes"), std::string::npos);
  o.appearance = false;
  const nlohmann::json k = to_json(compare(m, m, o));
  EXPECT_TRUE(k["texel_clashes"].is_null());
  EXPECT_TRUE(k["rendered"].is_null());
}

// The original M-method program's output of t078_L15 against its input: fewer charts, so fewer
// clashing texels at the coarse levels; rendered fidelity finite and below the identical pair's.
TEST(RealModels, AppearanceOfMMethodOutput) {
  TEXDEFRAG_REQUIRE_DATA(in, "contextcapture/rural_t007_078_L15/t078_L15.obj");
  TEXDEFRAG_REQUIRE_DATA(out, "mmethod_outputs/t078_L15/t078_L15_defrag.obj");
  EvalOptions o;
  o.fidelity.samples = 20000;
  o.render.size = 256, o.render.views = 3;
  const Comparison c = compare_files(in, out, o);
  ASSERT_TRUE(c.has_rendered && c.has_seam_colour && c.has_clashes);
  EXPECT_GT(c.clashes_input[3].clashes, c.clashes_output[3].clashes);
  EXPECT_GT(c.seam_colour_input.seam_edges, c.seam_colour_output.seam_edges);
  for (const RenderLevel& l : c.rendered.levels) {
    EXPECT_TRUE(std::isfinite(l.pair_psnr_db));
    EXPECT_GT(l.pair_ssim, 0.3);
    EXPECT_LT(l.pair_ssim, 1.0);
  }
}
