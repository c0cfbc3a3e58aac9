// Texture resampling: renders output atlas pages from the input pages, given the working atlas
// (input UVs are read from the TexturedMesh, output UVs from the Layout). Details: docs/texture.md.
//
// Each output triangle is rasterised on its output page (texel centres inside the triangle, with a
// conservative one-texel border so bilinear lookups near chart borders find colour: every texel
// whose centre is less than 1 texel away on both axes; interior texels are never overwritten by
// another triangle's border); every covered texel maps through the triangle's affine map to the
// input page and is sampled there (clamp-to-edge). A face whose map is a whole-texel translation
// plus a multiple of 90 degrees is copied texel for texel (bit-exact). The background around
// charts is then filled (pull-push or dilation) so MIP-mapping does not bleed background colour
// into charts.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"
#include "texdefrag/stage/stage.h"

#include <vector>

namespace texdefrag {

enum class Filter { Nearest, Bilinear, Bicubic };
enum class GutterFill { None, Dilate, PullPush };
/// How resampled texel values are chosen: Sample (each texel takes the input's value at its centre's
/// pre-image) or LeastSquares (starting there, the resampled texels are adjusted so that the
/// output page read bilinearly matches the input page read bilinearly through the face maps, in
/// least squares over each output triangle; docs/texture.md).
enum class TexelFit { Sample, LeastSquares };

struct ResampleOptions {
  /// Sampling of the input pages: Nearest, Bilinear, or Bicubic (Catmull-Rom, clamped to [0, 255]).
  Filter filter = Filter::Bilinear;
  /// Texel values of resampled (not copied) faces; copied texels are never changed.
  TexelFit fit = TexelFit::LeastSquares;
  /// Conjugate-gradient iterations of TexelFit::LeastSquares, >= 1.
  int fit_iterations = 4;
  /// Texels no triangle covers: PullPush (all filled from a pyramid of covered texels), Dilate
  /// (dilate_width rings, rest background) or None (background).
  GutterFill fill = GutterFill::PullPush;
  /// Texels of dilation around charts for GutterFill::Dilate (pull-push fills the whole page);
  /// >= 0 (negative throws StageError).
  int dilate_width = 8;
  /// After GutterFill::PullPush (the others keep their background), per 8 x 8 block of the page (JPEG's blocks, from
  /// the top-left corner): a block no triangle wrote takes its mean colour, and in a block partly
  /// written the unwritten texels take the harmonic (smoothest) continuation of the written ones
  /// inside the block. Written texels never change; it saves the bytes a JPEG page spends on
  /// gutter and empty space (docs/texture.md "Gutter fill").
  bool fill_blocks = true;
  /// RGBA of texels no fill reaches (fill None, beyond the dilation, or a page with no chart).
  /// Grey outputs use [0] (and [3] as alpha), RGB outputs [0..2].
  uint8_t background[4] = {0, 0, 0, 255};
};

struct ResampleStats {
  size_t texels_written = 0;     ///< texels written by output triangles (interior and border), once each
  size_t texels_copied = 0;      ///< of those, copied bit-exact (whole-texel translation/rotation)
  size_t faces_copied = 0;       ///< faces whose map allowed exact copying
  size_t faces_resampled = 0;    ///< other textured faces (zero-area output faces count here)
  size_t texels_fitted = 0;      ///< texels adjusted by TexelFit::LeastSquares
};

/// Renders the output pages. Layout::pages gives the sizes; the result has one Image per output
/// page, with the channel count of the input pages (the maximum, when they differ: grey is
/// replicated, missing alpha is 255). The result does not depend on the number of threads.
/// Throws StageError("texture.resample: ...") on inconsistent input and Cancelled when progress
/// returns false.
/// mesh: the input; faces with page != kNoPage are drawn, their input UVs from corner_texel().
/// input_pages: input_pages[i] is the image of mesh.pages[i] with its width and height; pages no
///   face uses may be empty. Not retained.
/// atlas: face_chart / face_wedge of every face (-1 for untextured faces, as in the mesh).
/// layout: output page sizes (1..65536), the output page of every chart, and every wedge's output
///   position in texels of that page (y up), finite and within 1e9 texels.
/// options: filter, fill and background. stats: filled when not null.
/// progress: called from the calling thread as ("texture.resample", fraction), may be empty.
std::vector<Image> resample_atlas(const TexturedMesh& mesh, const std::vector<Image>& input_pages,
                                  const Atlas& atlas, const Layout& layout,
                                  const ResampleOptions& options, ResampleStats* stats = nullptr,
                                  const ProgressFn& progress = nullptr);

}  // namespace texdefrag
