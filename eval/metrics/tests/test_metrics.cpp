// Evaluation metrics: hand-built meshes with hand-computed answers, exact overlap predicates
// against brute force, and invariants on the real tiles (eval(input, input), M-method outputs).
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

using namespace texdefrag;
using namespace texdefrag::eval;
namespace fx = texdefrag::testing;

namespace {

/// 2x1 grid of unit quads on a 100x100 page whose two quads are separate charts: the left quad
/// keeps grid_mesh's UVs (texels x 10..50, y 10..90), the right quad's UVs move by +5 texels in x
/// (x 55..95). Faces 0, 1 left; 2, 3 right.
TexturedMesh two_chart_grid() {
  TexturedMesh m = fx::grid_mesh(2, 1, 100, "unused.png");
  std::vector<int> moved(m.texcoords.size(), -1);
  for (size_t f = 2; f < 4; ++f)
    for (int& vt : m.faces[f].vt) {
      int& nv = moved[static_cast<size_t>(vt)];
      if (nv < 0) {
        nv = static_cast<int>(m.texcoords.size());
        m.texcoords.push_back(m.texcoords[static_cast<size_t>(vt)] + Vec2(0.05, 0));
      }
      vt = nv;
    }
  return m;
}

std::array<Vec2, 3> tri(double ax, double ay, double bx, double by, double cx, double cy) {
  return {Vec2(ax, ay), Vec2(bx, by), Vec2(cx, cy)};
}

Image solid(int w, int h, uint8_t r, uint8_t g, uint8_t b) {
  Image im;
  im.width = w;
  im.height = h;
  im.channels = 3;
  im.pixels.resize(static_cast<size_t>(w * h * 3));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* p = im.at(x, y);
      p[0] = r;
      p[1] = g;
      p[2] = b;
    }
  return im;
}

/// Deterministic noise image (every texel different from its neighbours).
Image noise(int w, int h, unsigned seed) {
  Image im = solid(w, h, 0, 0, 0);
  std::mt19937 rng(seed);
  for (uint8_t& v : im.pixels) v = static_cast<uint8_t>(rng() & 255u);
  return im;
}

/// Texel (x, y) with y up.
uint8_t* texel(Image& im, int x, int y) { return im.at(x, im.height - 1 - y); }

}  // namespace

// ------------------------------------------------------------------------------ per-model metrics

TEST(ModelMetrics, TwoChartGridByHand) {
  const ModelMetrics m = model_metrics(two_chart_grid());
  EXPECT_EQ(m.faces, 4u);
  EXPECT_EQ(m.v3, 6u);
  EXPECT_EQ(m.v2, 8u);  // the two middle vertices carry one UV per chart
  EXPECT_DOUBLE_EQ(m.vertex_replication, 8.0 / 6.0);
  EXPECT_EQ(m.charts, 2u);
  EXPECT_EQ(m.charts_nonzero, 2u);
  // Each chart is a 40 x 80 texel rectangle: border 2 * (40 + 80) each.
  EXPECT_NEAR(m.uv_border_length, 480.0, 1e-9);
  EXPECT_EQ(m.seam_edges, 1u);
  EXPECT_NEAR(m.seam_length_3d, 1.0, 1e-12);  // the middle edge (1,0,0)-(1,1,0), boundary excluded
  EXPECT_EQ(m.pages, 1u);
  EXPECT_DOUBLE_EQ(m.megapixels, 0.01);
  EXPECT_NEAR(m.uv_area, 2 * 40.0 * 80.0, 1e-9);
  EXPECT_NEAR(m.packing_efficiency, 0.64, 1e-12);
  EXPECT_EQ(m.uv_overlaps, 0u);  // the charts are 5 texels apart
  EXPECT_EQ(m.missing_page_files, 1u);
}

TEST(ModelMetrics, OneChartGridByHand) {
  const ModelMetrics m = model_metrics(fx::grid_mesh(2, 1, 100, "unused.png"));
  EXPECT_EQ(m.v2, 6u);
  EXPECT_EQ(m.charts, 1u);
  EXPECT_NEAR(m.uv_border_length, 2 * (80.0 + 80.0), 1e-9);
  EXPECT_EQ(m.seam_edges, 0u);
  EXPECT_EQ(m.seam_length_3d, 0.0);
}

TEST(ModelMetrics, FragmentedGridByHand) {
  // 2x1 grid, 4 triangles, each its own chart: cells of 0.5 page, triangle legs 0.4 * 64 texels.
  const ModelMetrics m = model_metrics(fx::fragmented_grid_mesh(2, 1, 64, "unused.png"));
  const double leg = 0.4 * 64;
  EXPECT_EQ(m.v3, 6u);
  EXPECT_EQ(m.v2, 12u);
  EXPECT_DOUBLE_EQ(m.vertex_replication, 2.0);
  EXPECT_EQ(m.charts, 4u);
  EXPECT_NEAR(m.uv_border_length, 4 * leg * (2 + std::sqrt(2.0)), 1e-9);
  EXPECT_EQ(m.seam_edges, 3u);  // two diagonals and the middle edge
  EXPECT_NEAR(m.seam_length_3d, 1 + 2 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(m.packing_efficiency, 4 * 0.5 * leg * leg / (64.0 * 64.0), 1e-12);
  EXPECT_EQ(m.uv_overlaps, 0u);
}

TEST(ModelMetrics, ZeroAreaChartsAndSharedImagePages) {
  TexturedMesh m = fx::fragmented_grid_mesh(2, 1, 64, "same.png");
  // Collapse face 3's UVs to a point: a zero-area chart.
  for (int vt : m.faces[3].vt) m.texcoords[static_cast<size_t>(vt)] = m.texcoords[static_cast<size_t>(m.faces[3].vt[0])];
  // A second material naming the same image (as MeshLab writes): still one page.
  m.materials.push_back(m.materials[0]);
  m.materials[1].name = "page1";
  m.pages.push_back(m.pages[0]);
  m.pages[1].material = "page1";
  m.faces[1].page = 1;
  const ModelMetrics r = model_metrics(m);
  EXPECT_EQ(r.pages, 1u);
  EXPECT_DOUBLE_EQ(r.megapixels, 64.0 * 64.0 / 1e6);
  EXPECT_EQ(r.charts, 4u);
  EXPECT_EQ(r.zero_area_charts, 1u);
  EXPECT_EQ(r.charts_nonzero, 3u);
}

TEST(ModelMetrics, UnknownPageSizeIsAnError) {
  TexturedMesh m = fx::grid_mesh(1, 1, 16, "x.png");
  m.pages[0].width = 0;
  EXPECT_THROW(model_metrics(m), std::invalid_argument);
}

// ------------------------------------------------------------------------------------ UV overlap

TEST(UvOverlap, HandCases) {
  const auto a = tri(0, 0, 2, 0, 0, 2);
  EXPECT_EQ(count_overlapping_pairs({a, tri(1, 1, 3, 1, 1, 3)}), 0u);          // touch at (1,1) on a's edge
  EXPECT_EQ(count_overlapping_pairs({a, tri(0.5, 0.5, 3, 0.5, 0.5, 3)}), 1u);  // proper crossing
  EXPECT_EQ(count_overlapping_pairs({a, tri(2, 0, 0, 2, 2, 2)}), 0u);          // shares the hypotenuse
  EXPECT_EQ(count_overlapping_pairs({a, tri(2, 0, 4, 0, 3, 1)}), 0u);          // shares a vertex
  EXPECT_EQ(count_overlapping_pairs({a, a}), 1u);                              // identical
  EXPECT_EQ(count_overlapping_pairs({a, tri(0.1, 0.1, 0.5, 0.1, 0.1, 0.5)}), 1u);  // contained
  EXPECT_EQ(count_overlapping_pairs({a, tri(1, 0, 3, 0, 1, 1)}), 1u);   // collinear edges, same side
  EXPECT_EQ(count_overlapping_pairs({a, tri(1, 0, 3, 0, 1, -1)}), 0u);  // collinear edges, other side
  EXPECT_EQ(count_overlapping_pairs({a, tri(0, 0, 1, 1, 2, 2)}), 0u);   // zero area never counts
  EXPECT_EQ(count_overlapping_pairs({a, tri(0, 2, 2, 0, 0, 0)}), 1u);   // same triangle, other orientation
  // Three mutually overlapping triangles: three pairs.
  EXPECT_EQ(count_overlapping_pairs({a, tri(0.2, 0.2, 1, 0.2, 0.2, 1), tri(0.3, 0.3, 0.9, 0.3, 0.3, 0.9)}), 3u);
}

TEST(UvOverlap, Orient2dIsExactNearCollinear) {
  // det((a, b, c)) = 12 (ay - ax) exactly for b = (12, 12), c = (24, 24).
  const double ulp = std::ldexp(1.0, -53);
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      const Vec2 a(0.5 + i * ulp, 0.5 + j * ulp);
      EXPECT_EQ(orient2d(a, Vec2(12, 12), Vec2(24, 24)), (j > i) - (j < i)) << i << " " << j;
    }
}

TEST(UvOverlap, GridMatchesBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(0, 100), size(-4, 4);
  std::vector<std::array<Vec2, 3>> tris;
  for (int i = 0; i < 600; ++i) {
    const Vec2 o(pos(rng), pos(rng));
    tris.push_back({o, o + Vec2(size(rng), size(rng)), o + Vec2(size(rng), size(rng))});
  }
  // Exact-touching cases on an integer lattice: shared edges and vertices.
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) {
      tris.push_back(tri(i, j, i + 1, j, i + 1, j + 1));
      tris.push_back(tri(i, j, i + 1, j + 1, i, j + 1));
    }
  size_t brute = 0;
  for (size_t i = 0; i < tris.size(); ++i)
    for (size_t j = i + 1; j < tris.size(); ++j)
      if (orient2d(tris[i][0], tris[i][1], tris[i][2]) != 0 && orient2d(tris[j][0], tris[j][1], tris[j][2]) != 0 &&
          triangle_interiors_overlap(tris[i], tris[j]))
        ++brute;
  EXPECT_GT(brute, 0u);
  EXPECT_EQ(count_overlapping_pairs(tris), brute);
}

TEST(UvOverlap, HundredThousandTrianglesQuickly) {
  // A 224 x 224 grid of cells with two triangles each (touching only), plus 50 overlapping extras.
  std::vector<std::array<Vec2, 3>> tris;
  const int n = 224;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      tris.push_back(tri(i, j, i + 1, j, i + 1, j + 1));
      tris.push_back(tri(i, j, i + 1, j + 1, i, j + 1));
    }
  for (int k = 0; k < 50; ++k) tris.push_back(tri(4 * k + 0.5, 0.1, 4 * k + 0.9, 0.1, 4 * k + 0.9, 0.4));
  const auto t0 = std::chrono::steady_clock::now();
  const size_t c = count_overlapping_pairs(tris);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ overlap ] %zu triangles in %.3f s\n", tris.size(), s);
  EXPECT_EQ(c, 50u);  // each extra lies inside one lower triangle of cell (4k, 0)
  EXPECT_LT(s, 5.0);  // ~0.1 s on one core; loose bound for a loaded machine
}

// --------------------------------------------------------------------------------- face matching

TEST(FaceMatching, ReorderedReorientedAndDroppedFaces) {
  const TexturedMesh in = fx::grid_mesh(2, 2, 64, "unused.png");  // 8 faces
  // Output: faces in reverse order, each with its own copies of positions and texcoords, corners
  // rotated; face 6 re-oriented (corners 1, 2 swapped); faces 3 and 5 dropped.
  TexturedMesh out = in;
  out.positions.clear();
  out.texcoords.clear();
  out.faces.clear();
  std::vector<int> expect_out(8, -1);
  for (int f = 7; f >= 0; --f) {
    if (f == 3 || f == 5) continue;
    const Face& src = in.faces[static_cast<size_t>(f)];
    std::array<int, 3> order = {1, 2, 0};
    if (f == 6) order = {0, 2, 1};
    Face g = src;
    for (int k = 0; k < 3; ++k) {
      const int c = order[static_cast<size_t>(k)];
      g.v[static_cast<size_t>(k)] = static_cast<int>(out.positions.size());
      out.positions.push_back(in.corner_position(static_cast<size_t>(f), c));
      g.vt[static_cast<size_t>(k)] = static_cast<int>(out.texcoords.size());
      out.texcoords.push_back(in.texcoords[static_cast<size_t>(src.vt[static_cast<size_t>(c)])]);
    }
    expect_out[static_cast<size_t>(f)] = static_cast<int>(out.faces.size());
    out.faces.push_back(g);
  }
  const FaceMatch m = match_faces(in, out);
  EXPECT_EQ(m.matched, 6u);
  EXPECT_EQ(m.lost, 2u);
  EXPECT_EQ(m.lost_other, 2u);
  EXPECT_EQ(m.added, 0u);
  EXPECT_EQ(m.moved_positions, 0u);
  EXPECT_EQ(m.snapped_positions, 0u);
  EXPECT_EQ(m.exact_positions, 8u);  // position (0, 2) was only in the dropped face 5
  for (size_t f = 0; f < 8; ++f) {
    EXPECT_EQ(m.output_of_input[f], expect_out[f]) << f;
    if (expect_out[f] < 0) continue;
    EXPECT_EQ(m.input_of_output[static_cast<size_t>(expect_out[f])], static_cast<int>(f));
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(out.corner_position(static_cast<size_t>(expect_out[f]), m.output_corner[f][static_cast<size_t>(k)]),
                in.corner_position(f, k));
  }
  // Same UVs through the correspondence: no distortion, nothing flipped (even the re-oriented face).
  const DistortionMetrics d = uv_distortion(in, out, m);
  EXPECT_EQ(d.faces, 6u);
  EXPECT_EQ(d.flipped, 0u);
  EXPECT_NEAR(d.arap, 0.0, 1e-20);
  EXPECT_NEAR(d.symmetric_dirichlet, 4.0, 1e-12);
}

TEST(FaceMatching, DuplicatesMovedPositionsAndLossReasons) {
  TexturedMesh in = fx::grid_mesh(1, 1, 16, "unused.png");  // faces 0, 1; positions 0..3
  in.faces.push_back(in.faces[0]);                                 // 2: duplicate of face 0
  Face degenerate = in.faces[0];
  degenerate.v = {0, 0, 1};
  in.faces.push_back(degenerate);  // 3
  in.positions.emplace_back(2, 0, 0);
  Face flat = in.faces[0];
  flat.v = {0, 1, 4};  // (0,0), (1,0), (2,0): collinear
  in.faces.push_back(flat);  // 4

  TexturedMesh out = in;
  out.faces = {in.faces[1], in.faces[0]};  // one copy of the duplicated face; 3 and 4 dropped
  // An added face with a moved position, and a position within the tolerance of (1,1,0).
  out.positions.emplace_back(0.5, 0.5, 1.0);      // 5: moved
  out.positions.emplace_back(1.0 + 4e-7, 1.0, 0);  // 6: MeshLab-style rounding of (1,1,0)
  Face added = in.faces[0];
  added.v = {0, 1, 5};
  out.faces.push_back(added);
  out.faces[0].v[static_cast<size_t>(std::find(out.faces[0].v.begin(), out.faces[0].v.end(), 3) - out.faces[0].v.begin())] = 6;

  const FaceMatch m = match_faces(in, out);
  EXPECT_EQ(m.matched, 2u);
  EXPECT_EQ(m.added, 1u);
  EXPECT_EQ(m.lost, 3u);
  // The second copy of face 0 makes edge (0,1) non-manifold (faces 0, 2, 4): that is its reason.
  EXPECT_EQ(m.lost_non_manifold, 1u);
  EXPECT_EQ(m.lost_other, 0u);
  EXPECT_EQ(m.lost_degenerate, 1u);
  EXPECT_EQ(m.lost_zero_area, 1u);
  EXPECT_EQ(m.moved_positions, 1u);
  EXPECT_EQ(m.snapped_positions, 1u);
  EXPECT_EQ(m.output_of_input[0], 1);  // first copy pairs with the first output face holding it
  EXPECT_EQ(m.output_of_input[1], 0);
  EXPECT_EQ(m.output_of_input[2], -1);

  MatchOptions exact;
  exact.position_tolerance = 0;
  const FaceMatch e = match_faces(in, out, exact);
  EXPECT_EQ(e.matched, 1u);  // face 1 now uses a position that is not an input position
  EXPECT_EQ(e.moved_positions, 2u);
  EXPECT_EQ(e.snapped_positions, 0u);
}

// ------------------------------------------------------------------------------------ distortion

TEST(Distortion, UvScaledByTwo) {
  // Same normalised UVs on a page twice as large: output texels = 2 x input texels.
  const TexturedMesh in = fx::grid_mesh(2, 1, 64, "unused.png");
  TexturedMesh out = in;
  out.pages[0].width = out.pages[0].height = 128;
  const DistortionMetrics d = uv_distortion(in, out, match_faces(in, out));
  EXPECT_EQ(d.faces, 4u);
  EXPECT_NEAR(d.arap, 2.0, 1e-12);                           // (2 - 1)^2 * 2
  EXPECT_NEAR(d.symmetric_dirichlet, 4 + 4 + 0.25 + 0.25, 1e-12);  // s^2 + s^2 + s^-2 + s^-2
  EXPECT_EQ(d.flipped, 0u);
  EXPECT_NEAR(d.weight, (0.8 * 64) * (0.8 * 64), 1e-6);  // UV area of the chart (texels^2)
}

TEST(Distortion, OneFlippedFaceCounted) {
  // grid_mesh(2, 1): one chart of 4 equal faces. Position 3 = (0, 1) belongs to face 1 only; mirror
  // its UV (in texels) across face 1's opposite edge (0,0)-(1,1): face 1's map becomes a reflection.
  const TexturedMesh in = fx::grid_mesh(2, 1, 64, "unused.png");
  ASSERT_EQ(in.faces[1].v[2], 3);
  TexturedMesh out = in;
  const Vec2 a = in.texcoords[0] * 64, b = in.texcoords[4] * 64, p = in.texcoords[3] * 64;  // (0,0) (1,1) (0,1)
  const Vec2 d = (b - a).normalized();
  out.texcoords[3] = (a + 2 * (p - a).dot(d) * d - (p - a)) / 64.0;
  const DistortionMetrics r = uv_distortion(in, out, match_faces(in, out));
  EXPECT_EQ(r.flipped, 1u);
  EXPECT_EQ(r.mirrored_charts, 0u);
  // Face 1: J is a reflection, signed singular values (1, -1): error 0 + 4; others 0; equal weights.
  EXPECT_NEAR(r.arap, 4.0 / 4.0, 1e-12);
  EXPECT_NEAR(r.symmetric_dirichlet, 4.0, 1e-12);  // over the three non-flipped faces
}

TEST(Distortion, MirroredChartsAreNotDistortion) {
  // The whole atlas mirrored (u -> 1 - u): every chart is a mirror image, no face folds.
  const TexturedMesh in = two_chart_grid();
  TexturedMesh out = in;
  for (Vec2& t : out.texcoords) t.x() = 1 - t.x();
  const DistortionMetrics r = uv_distortion(in, out, match_faces(in, out));
  EXPECT_EQ(r.mirrored_charts, 2u);
  EXPECT_EQ(r.mirrored_faces, 4u);
  EXPECT_EQ(r.flipped, 0u);
  EXPECT_NEAR(r.arap, 0.0, 1e-20);
}

// ------------------------------------------------------------------------------ texture fidelity

TEST(Fidelity, IdenticalIsInfiniteAndCopied) {
  const TexturedMesh m = fx::fragmented_grid_mesh(3, 2, 64, "unused.png");
  const std::vector<Image> pages = {noise(64, 64, 1)};
  FidelityOptions opt;
  opt.samples = 5000;
  const FidelityMetrics f = texture_fidelity(m, pages, m, pages, match_faces(m, m), opt);
  EXPECT_EQ(f.faces, 12u);
  EXPECT_GE(f.samples, 4000u);
  EXPECT_TRUE(std::isinf(f.psnr_db));
  EXPECT_DOUBLE_EQ(f.copied_fraction, 1.0);
  EXPECT_DOUBLE_EQ(f.rigid_fraction, 1.0);
}

TEST(Fidelity, SolidColoursGiveHandPsnr) {
  const TexturedMesh m = fx::fragmented_grid_mesh(1, 1, 32, "unused.png");
  const std::vector<Image> a = {solid(32, 32, 200, 120, 40)}, b = {solid(32, 32, 190, 120, 40)};
  const FidelityMetrics f = texture_fidelity(m, a, m, b, match_faces(m, m));
  EXPECT_NEAR(f.mse, 100.0 / 3.0, 1e-9);
  EXPECT_NEAR(f.psnr_db, 10 * std::log10(255.0 * 255.0 * 3.0 / 100.0), 1e-9);
  EXPECT_EQ(f.copied_fraction, 0.0);  // rigid map, but the texels differ
  EXPECT_DOUBLE_EQ(f.rigid_fraction, 1.0);
}

TEST(Fidelity, WholeTexelTranslationAndRotationAreCopies) {
  const TexturedMesh in = fx::fragmented_grid_mesh(2, 2, 64, "unused.png");
  const Image src = noise(64, 64, 3);
  FidelityOptions opt;
  opt.samples = 20000;
  {
    // Output page 80x80, content shifted by (+3, +5) texels, UVs likewise.
    TexturedMesh out = in;
    out.pages[0].width = out.pages[0].height = 80;
    for (Vec2& t : out.texcoords) t = (Vec2(t.x() * 64, t.y() * 64) + Vec2(3, 5)) / 80.0;
    Image dst = solid(80, 80, 0, 0, 0);
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        std::copy_n(src.at(x, 63 - y), 3, texel(dst, x + 3, y + 5));
    const FidelityMetrics f = texture_fidelity(in, {src}, out, {dst}, match_faces(in, out), opt);
    EXPECT_GT(f.psnr_db, 100.0);
    EXPECT_DOUBLE_EQ(f.copied_fraction, 1.0);
  }
  {
    // Rotation by 90 degrees: output texel (63 - y, x) holds input texel (x, y); UV p' = (64 - p.y, p.x).
    TexturedMesh out = in;
    for (Vec2& t : out.texcoords) t = Vec2(64 - t.y() * 64, t.x() * 64) / 64.0;
    Image dst = solid(64, 64, 0, 0, 0);
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        std::copy_n(src.at(x, 63 - y), 3, texel(dst, 63 - y, x));
    const FidelityMetrics f = texture_fidelity(in, {src}, out, {dst}, match_faces(in, out), opt);
    EXPECT_GT(f.psnr_db, 100.0);
    EXPECT_DOUBLE_EQ(f.copied_fraction, 1.0);
    EXPECT_DOUBLE_EQ(f.rigid_fraction, 1.0);
  }
  {
    // Scaled by 2 (resampled): not rigid, nothing copied.
    TexturedMesh out = in;
    out.pages[0].width = out.pages[0].height = 128;
    const FidelityMetrics f =
        texture_fidelity(in, {src}, out, {noise(128, 128, 4)}, match_faces(in, out), opt);
    EXPECT_EQ(f.rigid_faces, 0u);
    EXPECT_EQ(f.copied_fraction, 0.0);
    EXPECT_LT(f.psnr_db, 20.0);
  }
}

// An input whose charts lie at u = 37..38 (the MTL default addressing is repeat, as the resampler
// reads it) against an output reading the same texels inside [0, 1]: the same colours, unless the
// input's page says `-clamp on`, where those UVs read the page's edge column.
TEST(Fidelity, PagesAreReadWithTheirAddressing) {
  const TexturedMesh out = fx::fragmented_grid_mesh(2, 2, 64, "unused.png");
  TexturedMesh in = out;
  for (Vec2& t : in.texcoords) t.x() += 37;
  const std::vector<Image> pages = {noise(64, 64, 5)};
  FidelityOptions opt;
  opt.samples = 5000;
  EXPECT_GT(texture_fidelity(in, pages, out, pages, match_faces(in, out), opt).psnr_db, 100.0);
  in.pages[0].clamp = true;
  EXPECT_LT(texture_fidelity(in, pages, out, pages, match_faces(in, out), opt).psnr_db, 20.0);
}

TEST(Fidelity, ImageSizeMismatchIsAnError) {
  const TexturedMesh m = fx::grid_mesh(1, 1, 32, "unused.png");
  EXPECT_THROW(texture_fidelity(m, {solid(16, 16, 0, 0, 0)}, m, {solid(32, 32, 0, 0, 0)}, match_faces(m, m)),
               std::invalid_argument);
}

// ------------------------------------------------------------------------------------- reports

TEST(Report, JsonKeysAndNullForInfinity) {
  const TexturedMesh m = two_chart_grid();
  EvalOptions opt;
  opt.texture = false;
  Comparison c = compare(m, m, opt);
  c.has_fidelity = true;
  c.fidelity.psnr_db = std::numeric_limits<double>::infinity();
  const nlohmann::json j = to_json(c);
  EXPECT_EQ(j["input"]["charts"], 2);
  EXPECT_EQ(j["output"]["v2"], 8);
  EXPECT_EQ(j["matching"]["matched"], 4);
  EXPECT_EQ(j["matching"]["lost"], 0);
  EXPECT_EQ(j["relative_change"]["charts"], 0.0);
  EXPECT_TRUE(j["relative_change"]["uv_overlaps"].is_null());  // 0 -> 0
  EXPECT_TRUE(j["fidelity"]["psnr_db"].is_null());
  EXPECT_EQ(j["distortion"]["flipped"], 0);
  const std::string s = summary(c);
  EXPECT_NE(s.find("charts 2 (non-zero area 2)"), std::string::npos) << s;
  EXPECT_NE(s.find("PSNR inf"), std::string::npos) << s;
}

// ----------------------------------------------------------------------------------- real data

TEST(RealModels, EvalOfInputAgainstItself) {
  const auto models = fx::real_models(25000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  for (const std::string& path : models) {
    const auto t0 = std::chrono::steady_clock::now();
    const TexturedMesh mesh = read_obj(path);
    EvalOptions opt;
    opt.fidelity.samples = 200000;
    opt.appearance = false;  // identical pairs' appearance measures: test_appearance
    const Comparison c = compare(mesh, mesh, opt);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[ eval ] %s (%.1f s)\n%s", path.c_str(), s, summary(c).c_str());
    EXPECT_EQ(c.match.matched, mesh.faces.size()) << path;
    EXPECT_EQ(c.match.lost, 0u);
    EXPECT_EQ(c.match.added, 0u);
    EXPECT_EQ(c.match.moved_positions, 0u);
    EXPECT_LT(c.distortion.arap, 1e-12) << path;
    EXPECT_EQ(c.distortion.flipped, 0u) << path;
    EXPECT_TRUE(std::isinf(c.fidelity.psnr_db) || c.fidelity.psnr_db > 100) << path;
    EXPECT_EQ(c.fidelity.copied_fraction, 1.0) << path;
    EXPECT_EQ(c.input.uv_overlaps, c.output.uv_overlaps);
    EXPECT_GT(c.input.charts, 0u);
    EXPECT_GE(c.input.v2, c.input.v3);
    EXPECT_GT(c.input.page_bytes, 0u);
    EXPECT_EQ(c.input.missing_page_files, 0u);
  }
}

namespace {
/// Value of `key` in the M-method's log.txt ("Key value" lines), NaN when absent.
double log_value(const std::string& log, const std::string& key) {
  std::ifstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string k;
    double v;
    if (ss >> k >> v && k == key) return v;
  }
  return std::nan("");
}
}  // namespace

TEST(RealModels, MMethodOutputOfT078L15) {
  TEXDEFRAG_REQUIRE_DATA(in, "contextcapture/rural_t007_078_L15/t078_L15.obj");
  TEXDEFRAG_REQUIRE_DATA(out, "mmethod_outputs/t078_L15/t078_L15_defrag.obj");
  TEXDEFRAG_REQUIRE_DATA(log, "mmethod_outputs/t078_L15/log.txt");
  EvalOptions opt;
  opt.fidelity.samples = 300000;
  opt.appearance = false;  // this output's appearance measures: test_appearance
  const Comparison c = compare_files(in, out, opt);
  std::printf("%s", summary(c).c_str());
  const FaceMatch& m = c.match;
  EXPECT_EQ(m.matched + m.lost, c.input.faces);
  EXPECT_EQ(m.matched + m.added, c.output.faces);
  EXPECT_EQ(m.added, 0u);           // the M-method only drops faces
  EXPECT_GT(m.lost, 0u);            // ... and it does drop some (data README)
  EXPECT_EQ(m.lost_other, 0u);      // every dropped face is degenerate, zero-area or non-manifold
  EXPECT_EQ(m.moved_positions, 0u); // positions are only rounded by MeshLab's "%f"
  EXPECT_GT(m.snapped_positions, 0u);
  // Cross-check with the program's own log: output charts and megapixels.
  EXPECT_EQ(static_cast<double>(c.output.charts), log_value(log, "OutputCharts"));
  EXPECT_NEAR(c.output.megapixels, log_value(log, "OutputMP"), 1e-5);
  EXPECT_NEAR(c.input.megapixels, log_value(log, "InputMP"), 1e-5);
  EXPECT_NEAR(c.output.uv_border_length, log_value(log, "OutputUVLen"), 0.05);  // it prints 6 digits
  // Its share of faces placed on the input texel grid; ours is by area, its own by texels.
  EXPECT_NEAR(c.fidelity.rigid_fraction, log_value(log, "ZeroResamplingFraction"), 0.05);
  EXPECT_LT(c.output.charts, c.input.charts);
  EXPECT_GT(c.distortion.mirrored_charts, c.output.charts / 2);  // MeshLab output: mirrored atlas
  EXPECT_LE(c.distortion.arap, 0.025 * 1.2);  // its bound is 0.025 on its own (cleaned) mesh
  EXPECT_GT(c.fidelity.psnr_db, 20.0);
  std::printf("[ m-method ] ARAP %.5f (log: Atlas energy after optimization), rigid %.3f (log %.3f)\n",
              c.distortion.arap, c.fidelity.rigid_fraction, log_value(log, "ZeroResamplingFraction"));
}
