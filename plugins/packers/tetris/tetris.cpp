// packers.tetris: horizon ("Tetris") packing of rasterised chart outlines, after Lévy, Petitjean,
// Ray & Maillot 2002, "Least squares conformal maps for automatic texture atlas generation"
// (section 5, packing), as used by the M-method (Maggiordomo et al. 2021: rasterised outlines, four
// 90-degree rotations, gutter cells around each outline).
//
// Each chart is rasterised on the texel grid (conservatively, see geometry.h) and dilated by the
// gutter. Its bottom profile (lowest covered cell per column) and top profile (highest) are taken.
// Charts are dropped in decreasing area onto the page's top horizon H(x): for every column offset
// and every allowed rotation, the chart rests where its bottom profile first touches the horizon;
// the position with the least cost wins: area wasted between horizon and bottom profile plus the
// page area the drop adds above the page's current height (ties: lower resulting top, then
// leftmost). Lévy et al. minimise the wasted area; the added-area term stops charts from being
// stacked into towers when the page width is fixed. The horizon then becomes the chart's top profile over its columns.
// Space below the horizon is never reused (classic Tetris). Pages fill in order; a chart that fits
// no existing page under max_page_size opens a new one.
#include "texdefrag/packers/horizon.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <climits>

namespace texdefrag {
namespace {

using packing::CommonSettings;
using packing::PackChart;
using packing::PackInput;
using packing::PackResult;
using packing::Placement;
using packing::Drop;
using packing::Horizon;
using packing::Profile;

PackResult pack_tetris(const PackInput& in, const CommonSettings& s, const std::vector<int>& order,
                       const std::vector<std::vector<Profile>>& profiles, int width,
                       packing::TrialBound& bound, const StageContext& ctx) {
  PackResult r;
  r.placements.assign(in.charts.size(), Placement{});
  std::vector<Horizon> horizons;
  const int lo = s.gutter / 2;
  bound.start();
  for (size_t n = 0; n < order.size(); ++n) {
    if (bound.reports_progress() && (n & 255) == 0)
      ctx.step("packers.tetris", static_cast<double>(n) / static_cast<double>(order.size()));
    const int id = order[n];
    const auto& profs = profiles[static_cast<size_t>(id)];
    packing::place_on_pages(horizons, [&] { return Horizon(width); }, [&](size_t pg) {
      Horizon& hz = horizons[pg];
      Drop best;
      int best_q = 0;
      for (size_t q = 0; q < profs.size(); ++q) {
        if (profs[q].duplicate) continue;
        const Drop d = best_drop(hz, s.max_page_size, profs[q]);
        if (d.found && (!best.found || d.cost < best.cost || (d.cost == best.cost && d.top < best.top))) {
          best = d;
          best_q = static_cast<int>(q);
        }
      }
      if (!best.found) return false;
      const Profile& p = profs[static_cast<size_t>(best_q)];
      hz.place(p, best);
      r.placements[static_cast<size_t>(id)] = Placement{static_cast<int>(pg), best.x + lo, best.y + lo, best_q};
      bound.placed(in.charts[static_cast<size_t>(id)], r.placements[static_cast<size_t>(id)], s);
      return true;
    }, "packers.tetris", id, width);
    if (bound.hopeless(horizons.size(), s)) {
      packing::TrialBound::lose(r, horizons.size());
      return r;
    }
  }
  r.pages = static_cast<int>(horizons.size());
  return r;
}

class Tetris : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.tetris";
    i.kind = StageKind::Packer;
    i.description = "Classic horizon Tetris of rasterised outlines, 4 rotations (Levy et al. 2002, M-method)";
    i.doc = "docs/packers.md";
    i.options = packing::common_options(false, 2);
    i.create = [] { return std::make_unique<Tetris>(); };
    return i;
  }

  void pack(StageContext& ctx) override {
    const std::string name = "packers.tetris";
    const CommonSettings s = packing::read_common(options());
    const PackInput in = packing::prepare_charts(ctx, s, name);
    packing::check_chart_sizes(in, s, name);
    const std::vector<int> order = packing::order_by_area(in, s);
    std::vector<std::vector<Profile>> profiles(in.charts.size());
    // note: index = quarter turn; an orientation too large for the page never finds a drop.
    for (int id : order) profiles[static_cast<size_t>(id)] = packing::make_profiles(in.charts[static_cast<size_t>(id)], s);
    // note: once a width gives one page, later widths stop as soon as they cannot beat its area
    // (packing::TrialBound; same result as packing them fully).
    const PackResult r = packing::pack_best_width(
        in, s, [&](int width, packing::TrialBound& bound) {
          return pack_tetris(in, s, order, profiles, width, bound, ctx);
        });
    ctx.step(name, 1.0);
    packing::write_layout(ctx, in, r);
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::Tetris)
