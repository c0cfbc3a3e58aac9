// packers.row: an out-of-tree packer built on the exported packing helpers (texdefrag::packers_common):
// charts by decreasing height, left to right in rows of at most `row_width` texels, rows bottom to
// top, a new page when the page height would pass max_page_size. The helpers do the rest: chart
// outlines and texel-grid anchoring (prepare_charts), size checks, page trimming (size_pages) and
// the Layout plus report node (write_layout).
#include <texdefrag/packers/packing.h>
#include <texdefrag/stage/registry.h>

#include <algorithm>

namespace {

using namespace texdefrag;

class RowPacker final : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.row";
    i.kind = StageKind::Packer;
    i.description = "Charts by decreasing height in rows of a fixed width (out-of-tree example)";
    i.doc = "docs/writing-a-stage.md";
    i.options = packing::common_options(/*free_rotation_default=*/false, /*width_trials_default=*/1);
    i.options.push_back(opt_int("row_width", 2048, "Row width in texels").range(16, 16384));
    i.create = [] { return std::make_unique<RowPacker>(); };
    return i;
  }
  void pack(StageContext& ctx) override {
    const packing::CommonSettings s = packing::read_common(options());
    const int row_width = std::min(static_cast<int>(options().get_int("row_width")), s.max_page_size);
    const packing::PackInput in = packing::prepare_charts(ctx, s, info().name);
    packing::check_chart_sizes(in, s, info().name);
    std::vector<int> order = packing::order_by_area(in, s);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return in.charts[static_cast<size_t>(a)].h[0] > in.charts[static_cast<size_t>(b)].h[0];
    });
    packing::PackResult r;
    r.placements.resize(in.charts.size());
    int page = 0, x = 0, y = 0, row_h = 0;
    for (int c : order) {
      const packing::PackChart& ch = in.charts[static_cast<size_t>(c)];
      const int w = packing::padded_w(ch, 0, s), h = packing::padded_h(ch, 0, s);
      if (x > 0 && x + w > row_width) x = 0, y += row_h, row_h = 0;  // next row
      if (y + h > s.max_page_size) ++page, x = 0, y = 0, row_h = 0;   // next page
      r.placements[static_cast<size_t>(c)] = {page, x, y, 0};
      x += w;
      row_h = std::max(row_h, h);
    }
    r.pages = order.empty() ? 0 : page + 1;
    packing::size_pages(in, s, r);
    packing::write_layout(ctx, in, r);
    (*ctx.report)["row_width"] = row_width;
  }
};

}  // namespace

TEXDEFRAG_PLUGIN(RowPacker)
