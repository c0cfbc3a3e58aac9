// Appearance measures of a texture atlas under MIP-mapping (docs/eval.md, "Appearance"), after the
// measures the texture-atlas community uses (TexMetro, Yuksel et al.'s seam studies):
// - texel clashes per MIP level: texels of a box-filtered MIP level whose footprint mixes two
//   charts, or a chart and gutter (colour bleeding under minification);
// - seam colour discrepancy: the colour difference across 3D seam edges, read on both sides;
// - rendered-view fidelity: textured software renders of input and output from fixed views at
//   decreasing sizes with trilinear MIP-mapping, compared by PSNR and SSIM with a prefiltered
//   (supersampled) rendering of the input.
// Every function takes a mesh whose pages are canonicalised (canonical_pages) and sizes known.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"

#include <cstddef>
#include <vector>

namespace texdefrag::eval {

// ---------------------------------------------------------------------------------------------
// Images

/// Box-filtered MIP pyramid: level 0 is `img` as RGB (grey replicated, alpha dropped); level l+1
/// has size ceil(w/2) x ceil(h/2) and each texel is the rounded mean of the (up to) 2x2 texels of
/// level l it covers. Stops at 1x1 or at `max_level` (>= 0), whichever comes first.
std::vector<Image> mip_pyramid(const Image& img, int max_level);

/// Bilinear RGB colour at texel coordinates (x, y) of `img`, y up (as OBJ v), texel centres at
/// half-integers; 1-4 channels (grey replicated, alpha ignored). Outside the image the texels are
/// those of the page's addressing: clamped to the border, or with `repeat` (the MTL default,
/// core/mesh.h Page::clamp false) wrapped around, as the resampler reads them.
void bilinear_rgb(const Image& img, double x, double y, double rgb[3], bool repeat = false);

/// PSNR (dB) of two RGB images of equal size over the pixels where mask != 0: 10 log10(255^2 /
/// MSE), MSE the mean over masked pixels and channels; +infinity when equal; NaN when the mask is
/// empty. Throws std::invalid_argument on a size mismatch.
double psnr(const Image& a, const Image& b, const std::vector<uint8_t>& mask);

/// Mean SSIM (Wang et al. 2004) of the luma (0.299 R + 0.587 G + 0.114 B) of two RGB images,
/// Gaussian window sigma 1.5 (radius 5, truncated at the border and renormalised), C1 = (0.01
/// 255)^2, C2 = (0.03 255)^2, averaged over the pixels where mask != 0. Exactly 1 for identical
/// images; NaN when the mask is empty.
double ssim(const Image& a, const Image& b, const std::vector<uint8_t>& mask);

// ---------------------------------------------------------------------------------------------
// Texel clashes per MIP level

struct ClashLevel {
  int level = 0;
  size_t texels = 0;   ///< texels of the level, summed over pages
  size_t used = 0;     ///< texels whose footprint holds at least one chart texel
  size_t clashes = 0;  ///< used texels whose footprint mixes two charts, or a chart and gutter
  double fraction = 0; ///< clashes / used (0 when used = 0)
};

/// Texel clashes at MIP levels 0..max_level. Level 0: each texel belongs to the chart whose UV
/// triangle contains its centre (top-left rule on shared edges), to gutter when none does, and
/// clashes when triangles of two different charts contain it (UV overlap across charts). Level l:
/// the footprint of a texel is the 2^l x 2^l block of level-0 texels the box filter averages
/// (clipped at the page border); it clashes when that block holds two charts, a chart and gutter,
/// or a clashing texel. Charts are those of core/charts.h (UV-continuous components).
/// @param mesh       pages canonicalised, every used page of known size
/// @param max_level  highest level, >= 0 (levels beyond a page's 1x1 level repeat that level)
std::vector<ClashLevel> texel_clashes(const TexturedMesh& mesh, int max_level);

// ---------------------------------------------------------------------------------------------
// Seam colour discrepancy

/// Seam colour discrepancy read on one MIP level.
struct SeamColourLevel {
  int level = 0;
  double mean = 0;  ///< 3D-length-weighted mean RGB distance across the seam (8-bit levels)
  double rms = 0;   ///< root of the weighted mean squared RGB distance
  double max = 0;   ///< largest sampled distance
};

struct SeamColourMetrics {
  size_t seam_edges = 0;  ///< welded edges with two textured faces that are not UV-continuous
  size_t samples = 0;     ///< points sampled along them (the same points at every level)
  double length_3d = 0;   ///< model units: total 3D length of the seam edges
  double mean = 0;        ///< level 0: 3D-length-weighted mean RGB distance across the seam (8-bit levels)
  double rms = 0;         ///< level 0: root of the weighted mean squared RGB distance
  double max = 0;         ///< level 0: largest sampled distance
  std::vector<SeamColourLevel> levels;  ///< levels 0..max_level (levels[0] repeats mean, rms, max)
};

/// Colour discrepancy across the seams of a model: each seam edge (manifold, both faces textured,
/// not UV-continuous) is sampled at n points t = (i + 0.5) / n, n = ceil of the longer of its two
/// UV edges in texels of level 0, clamped to [1, 64]; at each point the colour is read bilinearly
/// through each face's UVs on its page and the Euclidean RGB distance is taken, weighted by the 3D
/// length / n. At MIP level l the same points are read on level l of each page's box-filtered
/// pyramid (mip_pyramid; texel coordinates u w_l, v h_l; a page smaller than 2^l reads its 1x1
/// level), as a renderer sampling that level shows the seam. A seam whose two sides show the same
/// texels scores 0 at level 0.
/// @param pages      one image per page of `mesh`
/// @param max_level  highest MIP level, >= 0
SeamColourMetrics seam_colour(const TexturedMesh& mesh, const std::vector<Image>& pages, int max_level = 0);

// ---------------------------------------------------------------------------------------------
// Rendered-view fidelity

/// The model seen from farther and farther away: distance step d renders it at size / 2^d pixels
/// (d = 0..max_level), as a renderer with trilinear MIP-mapping shows it, against a prefiltered
/// reference (the input at MIP level 0 rendered at size x supersample and box-filtered down).
struct RenderFidelityOptions {
  int views = 5;        ///< fixed view directions (see render_view_direction), >= 1
  int size = 512;       ///< pixels per side at distance step 0; a multiple of 2^max_level, size / 2^max_level >= 16
  int max_level = 4;    ///< distance steps 0..max_level (0..10)
  int supersample = 4;  ///< reference samples per pixel side at step 0 (size x supersample pixels rendered), >= 1
};

/// Fidelity at one distance step, over every view. Compared pixels: those whose whole footprint
/// in the supersampled reference is covered by the input (edge pixels, which mix background, are
/// left out); a face lost by the output shows background there and costs fidelity.
struct RenderLevel {
  int level = 0;              ///< distance step d
  int size = 0;               ///< render size at this step: size / 2^d pixels per side
  size_t pixels = 0;          ///< compared pixels, all views
  double input_psnr_db = 0;   ///< input rendered at this step vs the reference
  double input_ssim = 0;
  double output_psnr_db = 0;  ///< output rendered at this step vs the reference
  double output_ssim = 0;
  double pair_psnr_db = 0;    ///< output vs input, both rendered at this step
  double pair_ssim = 0;
};

struct RenderFidelity {
  int views = 0, size = 0, supersample = 0;
  std::vector<RenderLevel> levels;
};

/// Unit vector from the model toward the camera of view `i` of `n`: n - 1 views (n >= 5: the
/// last is straight down from above, else all) evenly spaced in azimuth from 30 degrees at 35
/// degrees elevation.
Vec3 render_view_direction(int i, int n);

/// A textured orthographic render: each pixel shows the texture of the nearest face read
/// bilinearly on MIP level `level` of its page (untextured faces grey 128, background black).
/// The framing is the bounding box of `frame`'s positions (so input and output share a camera).
/// @param pyramids  per page of `mesh`, mip_pyramid(page, >= level)
/// @param mask      set to 1 where a face covers the pixel (resized)
Image render_textured(const TexturedMesh& mesh, const std::vector<std::vector<Image>>& pyramids, const TexturedMesh& frame,
                      const Vec3& toward, int size, int level, std::vector<uint8_t>* mask);

/// Renders input and output from options.views directions at each distance step and compares
/// them with the prefiltered reference (RenderLevel). Each face is read with trilinear filtering
/// at the MIP level a GPU picks (log2 of the longer screen derivative of its texel coordinates),
/// so an atlas whose charts bleed into gutter or into each other at coarse levels loses fidelity
/// where a renderer would show it. All renders are framed by the input's bounding box.
/// @param in_pages, out_pages  one image per page of each mesh
/// @throws std::invalid_argument on options outside their ranges or a page count mismatch
RenderFidelity rendered_fidelity(const TexturedMesh& in, const std::vector<Image>& in_pages, const TexturedMesh& out,
                                 const std::vector<Image>& out_pages, const RenderFidelityOptions& options = {});

}  // namespace texdefrag::eval
