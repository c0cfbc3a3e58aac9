// UV overlap count (../shared/docs/METHOD.md section 3: "number of overlapping triangle pairs in the
// output atlas"). The exact predicates and the grid count are the core's (core/uv_overlap.cpp).
#include "texdefrag/eval/metrics.h"

#include "texdefrag/core/uv_overlap.h"

#include <stdexcept>
#include <string>

namespace texdefrag::eval {

// note: the predicates and the count live in the core (core/uv_overlap.h), shared with the
// framework's check after packing; these names are kept for eval's callers.
int orient2d(const Vec2& a, const Vec2& b, const Vec2& c) { return texdefrag::orient2d(a, b, c); }

bool triangle_interiors_overlap(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b) {
  return texdefrag::triangle_interiors_overlap(a, b);
}

size_t count_overlapping_pairs(const std::vector<std::array<Vec2, 3>>& all) { return texdefrag::count_overlapping_pairs(all); }

size_t count_uv_overlaps(const TexturedMesh& mesh) {
  std::vector<std::vector<std::array<Vec2, 3>>> per_page(mesh.pages.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const int p = mesh.faces[f].page;
    if (p == kNoPage) continue;
    if (p < 0 || static_cast<size_t>(p) >= mesh.pages.size())
      throw std::invalid_argument("eval: face " + std::to_string(f) + " names page " + std::to_string(p) + " of " +
                                  std::to_string(mesh.pages.size()));
    per_page[static_cast<size_t>(p)].push_back({mesh.corner_texel(f, 0), mesh.corner_texel(f, 1), mesh.corner_texel(f, 2)});
  }
  size_t total = 0;
  for (const auto& tris : per_page) total += count_overlapping_pairs(tris);
  return total;
}

}  // namespace texdefrag::eval
