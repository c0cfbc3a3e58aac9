// Test helper shared by the mergers' real-tile tests: overlapping UV triangle pairs within charts,
// counted with eval's exact test. Include after test_support.h; link texdefrag::eval.
#pragma once

#include "test_support.h"
#include "texdefrag/eval/metrics.h"

#include <array>
#include <map>
#include <utility>
#include <vector>

namespace texdefrag::merge::test {

/// Overlapping triangle pairs within charts: of the input (the faces' input texels, per output chart
/// and input page) and of the atlas (per output chart). A merger never adds any: out <= in.
inline std::pair<size_t, size_t> overlaps_in_out(const Run& run) {
  const Atlas& at = run.ctx.atlas;
  std::map<std::pair<int, int>, std::vector<std::array<Vec2, 3>>> in_tris;
  std::vector<std::vector<std::array<Vec2, 3>>> out_tris(static_cast<size_t>(at.num_charts));
  for (size_t f = 0; f < run.mesh.faces.size(); ++f) {
    if (run.mesh.faces[f].page == kNoPage) continue;
    const int c = at.face_chart[f];
    in_tris[{c, run.mesh.faces[f].page}].push_back(
        {run.mesh.corner_texel(f, 0), run.mesh.corner_texel(f, 1), run.mesh.corner_texel(f, 2)});
    const auto& w = at.face_wedge[f];
    out_tris[static_cast<size_t>(c)].push_back({at.wedge_uv[static_cast<size_t>(w[0])],
                                               at.wedge_uv[static_cast<size_t>(w[1])],
                                               at.wedge_uv[static_cast<size_t>(w[2])]});
  }
  size_t in = 0, out = 0;
  for (const auto& [key, tris] : in_tris) in += eval::count_overlapping_pairs(tris);
  for (const auto& tris : out_tris) out += eval::count_overlapping_pairs(tris);
  return {in, out};
}

}  // namespace texdefrag::merge::test
