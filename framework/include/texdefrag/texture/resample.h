// Texture resampling: renders output atlas pages from the input pages, given the working atlas
// (input UVs are read from the TexturedMesh, output UVs from the Layout).
//
// Each output triangle is rasterised on its output page (texel centres inside the triangle, with a
// conservative one-texel border so bilinear lookups near chart borders find colour); every covered
// texel maps through the triangle's affine map to the input page and is sampled there. A face whose
// map is a whole-texel translation plus a multiple of 90 degrees is copied texel for texel (bit-exact).
// The background around charts is then filled (pull-push or dilation) so MIP-mapping does not bleed
// background colour into charts.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"
#include "texdefrag/stage/stage.h"

#include <vector>

namespace texdefrag {

enum class Filter { Nearest, Bilinear, Bicubic };
enum class GutterFill { None, Dilate, PullPush };

struct ResampleOptions {
  Filter filter = Filter::Bilinear;
  GutterFill fill = GutterFill::PullPush;
  /// Texels of dilation around charts for GutterFill::Dilate (pull-push fills the whole page).
  int dilate_width = 8;
  /// RGB(A) of texels not covered by any chart when fill is None.
  uint8_t background[4] = {0, 0, 0, 255};
};

struct ResampleStats {
  size_t texels_written = 0;     ///< texels covered by output triangles
  size_t texels_copied = 0;      ///< of those, copied bit-exact (whole-texel translation/rotation)
  size_t faces_copied = 0;       ///< faces whose map allowed exact copying
  size_t faces_resampled = 0;
};

/// Renders the output pages. input_pages[i] is the image of mesh.pages[i]. Layout::pages gives the
/// sizes; the result has one Image per output page, with the channel count of the input pages
/// (the maximum, when they differ).
std::vector<Image> resample_atlas(const TexturedMesh& mesh, const std::vector<Image>& input_pages,
                                  const Atlas& atlas, const Layout& layout,
                                  const ResampleOptions& options, ResampleStats* stats = nullptr,
                                  const ProgressFn& progress = nullptr);

}  // namespace texdefrag
