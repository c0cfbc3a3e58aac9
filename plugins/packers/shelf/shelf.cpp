// packers.shelf: the simplest baseline packer. Charts keep their orientation and the input texel
// density; each is moved by a whole-texel translation (so untouched charts are copied bit-exact),
// sorted by height and laid left to right on shelves; a new page starts when a page is full.
#include "texdefrag/packers/packing.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace texdefrag {
namespace {

using Vec2i = Eigen::Vector2i;

/// Whole-texel bounding boxes [lo, hi) and UV areas of an atlas's charts (a chart without faces
/// keeps lo = INT32_MAX, hi = INT32_MIN).
struct ChartBoxes {
  std::vector<Vec2i> lo, hi;
  std::vector<double> area;  ///< texels^2, sum of |face UV area|
  Vec2i size(size_t c) const { return hi[c] - lo[c]; }
};

ChartBoxes chart_boxes(const Atlas& a) {
  const size_t nc = static_cast<size_t>(a.num_charts);
  ChartBoxes b{std::vector<Vec2i>(nc, Vec2i::Constant(INT32_MAX)), std::vector<Vec2i>(nc, Vec2i::Constant(INT32_MIN)),
               std::vector<double>(nc, 0.0)};
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    const int c = a.face_chart[f];
    if (c < 0) continue;
    const size_t ci = static_cast<size_t>(c);
    b.area[ci] += std::abs(atlas_face_area(a, static_cast<int>(f)));
    for (int w : a.face_wedge[f]) {
      const Vec2& p = a.wedge_uv[static_cast<size_t>(w)];
      b.lo[ci] = b.lo[ci].cwiseMin(Vec2i(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y()))));
      b.hi[ci] = b.hi[ci].cwiseMax(Vec2i(static_cast<int>(std::ceil(p.x())), static_cast<int>(std::ceil(p.y()))));
    }
  }
  return b;
}

/// The shelves' page width: sqrt of the boxes' padded area, at least the widest padded box, at
/// most max_size. Throws StageError naming the first chart that does not fit max_size.
int shelf_width(const ChartBoxes& b, int gutter, int max_size) {
  double box_area = 0;
  int widest = 0;
  for (size_t c = 0; c < b.lo.size(); ++c) {
    const Vec2i s = b.size(c);
    if (s.x() + 2 * gutter > max_size || s.y() + 2 * gutter > max_size)
      throw StageError("packers.shelf: chart " + std::to_string(c) + " is " + std::to_string(s.x()) + "x" +
                       std::to_string(s.y()) + " texels; with a gutter of " + std::to_string(gutter) +
                       " it does not fit in max_page_size " + std::to_string(max_size));
    box_area += static_cast<double>(s.x() + gutter) * (s.y() + gutter);
    widest = std::max(widest, s.x() + 2 * gutter);
  }
  return std::min(max_size, std::max(widest, static_cast<int>(std::ceil(std::sqrt(box_area)))));
}

/// Chart ids by decreasing box height (ties: id).
std::vector<int> by_height(const ChartBoxes& b) {
  std::vector<int> order(b.lo.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int x, int y) {
    const int hx = b.size(static_cast<size_t>(x)).y(), hy = b.size(static_cast<size_t>(y)).y();
    return hx != hy ? hx > hy : x < y;
  });
  return order;
}

/// Lays the boxes on shelves of `width`, in `order`, a new page when one is full: fills
/// L.chart_page and returns each chart's whole-texel move; used: per page, its used extent.
std::vector<Vec2i> place_on_shelves(const ChartBoxes& b, const std::vector<int>& order, int gutter, int width,
                                    int max_size, Layout& L, std::vector<Vec2i>& used) {
  const size_t nc = b.lo.size();
  L.chart_page.assign(nc, -1);
  std::vector<Vec2i> shift(nc, Vec2i::Zero());
  int page = -1, x = 0, y = 0, shelf_h = 0;
  auto new_page = [&] {
    ++page;
    used.emplace_back(0, 0);
    x = gutter;
    y = gutter;
    shelf_h = 0;
  };
  if (nc) new_page();
  for (int c : order) {
    const size_t ci = static_cast<size_t>(c);
    const Vec2i s = b.size(ci);
    if (x + s.x() + gutter > width) {  // next shelf
      x = gutter;
      y += shelf_h + gutter;
      shelf_h = 0;
    }
    if (y + s.y() + gutter > max_size) new_page();
    L.chart_page[ci] = page;
    shift[ci] = Vec2i(x, y) - b.lo[ci];
    used[static_cast<size_t>(page)] = used[static_cast<size_t>(page)].cwiseMax(Vec2i(x + s.x() + gutter, y + s.y() + gutter));
    x += s.x() + gutter;
    shelf_h = std::max(shelf_h, s.y());
  }
  return shift;
}

/// L.wedge_uv: the atlas's UVs, each wedge of a chart moved by its chart's shift.
void move_wedges(const Atlas& a, const std::vector<Vec2i>& shift, Layout& L) {
  L.wedge_uv = a.wedge_uv;
  std::vector<uint8_t> moved(a.wedge_uv.size(), 0);
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    const int c = a.face_chart[f];
    if (c < 0) continue;
    for (int w : a.face_wedge[f])
      if (!moved[static_cast<size_t>(w)]) {
        moved[static_cast<size_t>(w)] = 1;
        L.wedge_uv[static_cast<size_t>(w)] += shift[static_cast<size_t>(c)].cast<double>();
      }
  }
}

class ShelfPacker final : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.shelf";
    i.kind = StageKind::Packer;
    i.description = "Shelf packing of chart bounding boxes at the input texel density, whole-texel moves";
    i.doc = "plugins/packers/shelf/README.md";
    i.options = {
        opt_int("gutter", 4, "Empty texels between charts and around the page border").range(0, 64).unit("texels"),
        opt_int("max_page_size", 8192, "Largest page width and height; more pages are made when charts do not fit")
            .range(64, 32768).unit("texels"),
        opt_int("page_multiple", 32, "Page sides are rounded up to a multiple of this").range(1, 4096).unit("texels"),
        opt_bool("power_of_two", false, "Round page sides up to a power of two instead of page_multiple"),
    };
    i.create = [] { return std::make_unique<ShelfPacker>(); };
    return i;
  }

  void pack(StageContext& ctx) override {
    const Atlas& a = ctx.atlas;
    const int gutter = static_cast<int>(options().get_int("gutter"));
    const int max_size = static_cast<int>(options().get_int("max_page_size"));
    packing::CommonSettings sizing;  // only the page-sizing fields; shelf never rotates
    sizing.max_page_size = max_size;
    sizing.page_multiple = static_cast<int>(options().get_int("page_multiple"));
    sizing.power_of_two = options().get_bool("power_of_two");
    const ChartBoxes boxes = chart_boxes(a);
    const int width = shelf_width(boxes, gutter, max_size);
    Layout& L = ctx.layout;
    L = Layout();
    std::vector<Vec2i> used;  // per page: used extent
    const std::vector<Vec2i> shift = place_on_shelves(boxes, by_height(boxes), gutter, width, max_size, L, used);
    for (const auto& u : used)
      L.pages.push_back({packing::round_page_side(u.x(), sizing), packing::round_page_side(u.y(), sizing)});
    move_wedges(a, shift, L);
    double page_area = 0, chart_area = std::accumulate(boxes.area.begin(), boxes.area.end(), 0.0);
    json sizes = json::array();
    for (const auto& p : L.pages) {
      page_area += static_cast<double>(p.width) * p.height;
      sizes.push_back({p.width, p.height});
    }
    json& r = *ctx.report;
    r["pages"] = L.pages.size();
    r["page_sizes"] = sizes;
    r["packing_efficiency"] = page_area > 0 ? chart_area / page_area : 0.0;
    r["charts"] = boxes.lo.size();
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::ShelfPacker)
