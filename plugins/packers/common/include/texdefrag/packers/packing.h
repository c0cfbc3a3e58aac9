// Shared machinery of the packers (packers.square_tetris, packers.tetris, packers.shelf): common
// options, per-chart preparation (outline, orientation, texel-grid anchoring), page sizing, and
// writing the Layout and the report node.
//
// Exact copying (METHOD.md section 2, "shift anchors onto the input texel grid"): a face whose
// working UVs are its input UVs rotated by a multiple of 90 degrees and translated is "grid-exact".
// A chart whose largest group of grid-exact faces (same quarter turn, same fractional translation)
// covers at least `exact_fraction` of its UV area is an EXACT chart: it is only ever rotated by
// multiples of 90 degrees and translated so that the group's input texel grid lands on the output
// texel grid, hence the resampler copies those faces texel for texel. Other charts are FREE: they
// may be rotated by any angle (the minimum-area rectangle's, when `free_rotation` is on and the
// rectangle shrinks by more than `rotation_gain`).
//
// Footprints: a chart in orientation q (q quarter turns after its base transform) covers the cell
// box [floor(min), ceil(max)) of its bounding box (see geometry.h); packers place those cell boxes
// at integer positions with `gutter` empty cells between charts.
#pragma once

#include "texdefrag/packers/geometry.h"
#include "texdefrag/stage/stage.h"

#include <array>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace texdefrag::packing {

/// Options shared by every packer, read from the stage's validated Options.
struct CommonSettings {
  int gutter = 4;               ///< texels of empty space between charts, [0, 64]
  int max_page_size = 8192;     ///< texels, largest page width and height
  int page_multiple = 32;       ///< page sides are rounded up to this multiple (texels)
  bool power_of_two = false;    ///< round page sides up to a power of two instead
  bool allow_rotation = true;   ///< charts may be turned by 90/180/270 degrees
  bool free_rotation = false;   ///< free charts may be rotated to their minimum-area rectangle
  double rotation_gain = 0.05;  ///< relative rectangle-area gain required for a free rotation
  double exact_fraction = 0.25; ///< grid-exact share of a chart's UV area that makes it exact
  int width_trials = 5;         ///< page widths tried when everything fits on one page, [1, 16]
  /// Block grid (texels; 0 or 1 = off), set by packers that declare the option (square_tetris's
  /// `block_grid`): an exact chart is placed so that its anchor's input texel grid lands on the
  /// output texel grid with the input page's G x G blocks (JPEG's 8 x 8) on the output page's G x G
  /// blocks (both counted from the image's top-left corner; output page heights are multiples of G).
  int block_grid = 0;
};

/// Declarations of the common options, appended to each packer's StageInfo::options.
/// free_rotation_default: the default of `free_rotation` for this packer.
/// width_trials_default: the default of `width_trials` (each trial is a full packing run), 1..16.
std::vector<OptionSpec> common_options(bool free_rotation_default, int width_trials_default);

/// Reads the common options from validated stage options (every key present).
CommonSettings read_common(const Options& options);

/// One chart prepared for packing.
struct PackChart {
  int id = -1;                 ///< chart index in the atlas
  std::vector<int> faces;      ///< faces of the chart (textured, in face order)
  std::vector<int> wedges;     ///< distinct wedges used by those faces
  double uv_area = 0;          ///< texels^2, sum of |face UV area|
  bool exact = false;          ///< placed with 90-degree turns and grid-aligned translation only
  double exact_area = 0;       ///< texels^2 of the anchoring grid-exact face group
  double angle = 0;            ///< radians, free rotation applied before the quarter turns (0 if exact)
  Vec2 grid_offset = Vec2::Zero();  ///< subtracted after rotation so the anchor grid is integral
  std::vector<Vec2> base;      ///< per entry of `wedges`: rotate(uv, angle) - grid_offset
  std::vector<std::array<int, 3>> tris;  ///< per entry of `faces`: corner indices into `base`
  /// Cell box size in orientation q = 0..3 (quarter turns applied to `base`), texels.
  int w[4] = {1, 1, 1, 1}, h[4] = {1, 1, 1, 1};
  /// Lowest cell corner of the box in orientation q: floor of the rotated base's minimum; the box
  /// is [ox, ox + w) x [oy, oy + h) with w = max(1, ceil(max x) - ox) (same for h).
  int ox[4] = {0, 0, 0, 0}, oy[4] = {0, 0, 0, 0};
  /// Block grid (CommonSettings::block_grid = G > 1, exact charts only; `block_aligned` false
  /// otherwise): in orientation q the chart's Placement must have x = bx[q] and y = by[q] modulo G,
  /// in [0, G).
  bool block_aligned = false;
  int bx[4] = {0, 0, 0, 0}, by[4] = {0, 0, 0, 0};

  /// Cell box area in orientation 0 (texels^2).
  long long box_area() const { return static_cast<long long>(w[0]) * h[0]; }
  /// The rasterised outline in orientation q, cell (0,0) = box corner (ox[q], oy[q]).
  Mask raster(int q) const;
};

/// The charts of an atlas, prepared.
struct PackInput {
  const Atlas* atlas = nullptr;
  std::vector<PackChart> charts;  ///< one per atlas chart, index = chart id
  double total_uv_area = 0;       ///< texels^2
};

/// Extracts and prepares every chart of ctx.atlas. Exactness is judged against the input UVs of
/// ctx.mesh (when ctx.mesh is null, e.g. packer unit tests on bare atlases, the atlas UVs are
/// taken as the input UVs, so every chart is exact). Throws StageError (prefixed with
/// `stage`) when the atlas is inconsistent (a wedge shared by two charts, a chart id out of range).
PackInput prepare_charts(const StageContext& ctx, const CommonSettings& s, const std::string& stage);

/// Turns free chart c (not exact; prepared by prepare_charts) to `angle` radians: sets c.angle, its
/// base points (its wedges' UVs in atlas `a` rotated by `angle` counter-clockwise about the origin,
/// as preparation does with the minimum-area angle) and its boxes. So a packing can be redone with
/// other angles (square_tetris's angle search). Throws std::logic_error for an exact chart.
void set_free_angle(PackChart& c, const Atlas& a, double angle);

/// Whether chart c with its gutter fits a max_page_size square in some allowed orientation (with
/// its block-grid slack).
bool fits_max_page(const PackChart& c, const CommonSettings& s);

/// Where one chart went: its cell box (without gutter) has its lowest corner at (x, y) on `page`,
/// in orientation q (quarter turns).
struct Placement {
  int page = -1;
  int x = 0, y = 0;
  int q = 0;
};

/// Checks every chart fits in a max_page_size square with its gutter in some allowed orientation;
/// throws StageError naming the first chart that does not (id, faces, size, limit).
void check_chart_sizes(const PackInput& in, const CommonSettings& s, const std::string& stage);

/// A page side rounded up to the page multiple (or power of two), capped at max_page_size.
/// used: texels >= 0.
int round_page_side(int used, const CommonSettings& s);

/// Starting page width for single-page packing: sqrt(padded area / expected_efficiency), at least
/// the widest chart's narrowest padded side, at most max_page_size, rounded to the page multiple.
/// padded_area: texels^2 of the charts' cell boxes grown by the gutter.
int initial_page_width(double padded_area, int min_width, double expected_efficiency,
                       const CommonSettings& s);

/// Result of a packer's run on one candidate page width.
struct PackResult {
  std::vector<Placement> placements;  ///< per chart
  int pages = 0;
  std::vector<Layout::PageSize> sizes;  ///< trimmed and rounded page sizes
  size_t hole_fills = 0;                ///< charts placed into enclosed unused space (square_tetris)
  size_t outline_drops = 0;             ///< small charts dropped by outline (square_tetris tail)
  double total_area() const;            ///< texels^2 of all pages
};

/// The single-page results of a set of width trials that may run side by side (pack_best_width):
/// trial i's page area once it packed everything on one page. Thread-safe.
class TrialBoard {
 public:
  explicit TrialBoard(size_t trials) : single_(trials, -1.0) {}
  /// Records trial `index`'s finished, sized result (kept only when it is a single page).
  void record(size_t index, const PackResult& r);
  /// Whether trial `index`, with `pages` pages open and page 0 of `area` texels^2 so far, cannot
  /// win: another trial packed everything on one page and this one has more pages, or already
  /// needs more area than that page, or as much when the other trial's index is lower (ties keep
  /// the earlier width).
  bool beaten(size_t index, size_t pages, double area) const;
  /// Records a single page of `area` texels^2 found before this set (an earlier packing that every
  /// trial must beat: one needing as much area or more pages cannot). ties_lose false: a trial
  /// needing exactly `area` still counts (a bar the caller keeps a trial under, not a rival).
  void seed(double area, bool ties_lose = true) {
    seed_ = area;
    seed_ties_lose_ = ties_lose;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<double> single_;  ///< per trial, < 0: no single page (yet)
  double seed_ = -1;            ///< < 0: none
  bool seed_ties_lose_ = true;  ///< whether a trial needing exactly seed_ is beaten
};

/// Early stop of pack_best_width's width trials, with the same result as packing every width in
/// full: once one width packed everything on a single page, a trial that opens a second page, or
/// whose page 0 already needs at least that page's area (more than it, for a later width), cannot
/// win (pages only grow; ties keep the earlier width). Whatever order the trials run in, the
/// chosen width and its layout are those of packing every width in full. Used by packers.tetris
/// and packers.square_tetris.
class TrialBound {
 public:
  /// Trial `index` of the set that `board` records (board outlives the bound).
  TrialBound(const TrialBoard& board, size_t index) : board_(&board), index_(index) {}
  /// Starts a trial (page 0 empty).
  void start() { used_w_ = used_h_ = 0; }
  /// Notes chart c placed with p (its page-0 footprint as size_pages trims it).
  void placed(const PackChart& c, const Placement& p, const CommonSettings& s);
  /// Page 0's area so far (texels^2): its used sides rounded as size_pages rounds them; what
  /// hopeless compares with the recorded single pages.
  double area(const CommonSettings& s) const;
  /// Whether the running trial, with `pages` pages open, cannot beat a recorded single page.
  bool hopeless(size_t pages, const CommonSettings& s) const;
  /// Marks a trial stopped as hopeless as losing (more pages than the recorded single page).
  static void lose(PackResult& r, size_t pages);
  /// Whether this trial reports progress: the first of its set (it runs on the calling thread,
  /// util/parallel.h).
  bool reports_progress() const { return index_ == 0; }

 private:
  const TrialBoard* board_;
  size_t index_;
  int used_w_ = 0, used_h_ = 0;
};

/// Packs with a few page widths and keeps the result with the fewest pages, then the least page
/// area. When the charts' padded area is near or above one max_page_size page, only
/// max_page_size is tried; otherwise `width_trials` widths from initial_page_width at expected
/// efficiencies 1.0 down to 0.6. The widths are packed side by side (util/parallel.h; the result
/// does not depend on the thread count); each result is sized (size_pages) once and recorded in a
/// TrialBoard, through which the packer's TrialBound may stop a hopeless trial early.
/// pack_with_width(width, bound): packs every chart with pages of the given width (texels) and
/// height limit max_page_size; must return one Placement per chart (page -1 for charts without
/// faces), or a result marked TrialBound::lose when bound.hopeless stopped it.
PackResult pack_best_width(const PackInput& in, const CommonSettings& s,
                           const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width);

/// The same with the area the packer expects its charts to need, instead of the charts' padded
/// cell boxes: a packer that places outlines in each other's box corners needs less than its boxes
/// (square_tetris's outline tail: 2.64 MP of page for 3.7 MP of boxes on t078_L17), and widths
/// from the box area alone are all too wide there.
/// padded_area: texels^2, > 0 (e.g. boxes of rectangles + dilated outline cells of the rest).
PackResult pack_best_width(const PackInput& in, const CommonSettings& s, double padded_area,
                           const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width);

/// The page widths pack_best_width tries for charts needing `padded_area` texels^2 (see there).
std::vector<int> trial_widths(const PackInput& in, const CommonSettings& s, double padded_area);

/// The narrowest page width every chart fits in with its gutter (some allowed turn), texels.
int min_page_width(const PackInput& in, const CommonSettings& s);

/// A job pack_widths runs beside its width trials, on a thread that would otherwise wait: once
/// every trial has started, the first thread left without one calls it with the leader at that
/// moment, i.e. what pack_widths and its caller would keep if no running trial finished better
/// (the best finished trial, or the incumbent when none beats it): `leader` is its index in
/// `widths`, or -1 for the incumbent, and `result` its sized result. Not called when no trial has
/// finished and there is no incumbent. With one thread it runs after every trial (the leader is
/// then the result). It must not throw, and must not call what must stay on the calling thread
/// (progress callbacks): it may run on any thread of the loop.
using BesideJob = std::function<void(int leader, const PackResult& result)>;

/// Packs each of `widths` (side by side, a TrialBoard stopping hopeless trials) and returns the
/// best: the fewest pages, then the least page area, then the earliest width; its width goes to
/// *chosen when given. The result does not depend on the thread count. widths: not empty, each at
/// least min_page_width. pack_with_width: as for pack_best_width. incumbent: an earlier result the
/// caller keeps unless one of these beats it (better_result); when it is a single page, trials stop
/// as soon as they cannot beat it (a stopped trial's result is marked losing, TrialBound::lose).
/// bar (> 0, without incumbent): the caller keeps the result only when it is one page of at most
/// bar texels^2, so trials stop as soon as they open a second page or need more than that.
/// beside: when not empty, run beside the last trials (BesideJob).
PackResult pack_widths(const PackInput& in, const CommonSettings& s, const std::vector<int>& widths,
                       const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width,
                       int* chosen = nullptr, const PackResult* incumbent = nullptr, double bar = -1,
                       const BesideJob& beside = {});

/// Whether a beats b: fewer pages, or as many and less page area (sized results).
bool better_result(const PackResult& a, const PackResult& b);

/// Sum of the charts' cell boxes grown by the gutter, orientation 0 (texels^2).
double padded_box_area(const PackInput& in, const CommonSettings& s);

/// Places one chart on the first page that takes it, pages in order, opening a page when none
/// does (the page loop of packers.tetris and packers.square_tetris).
/// pages: the open pages (any container with size() and push_back). make_page(): a new empty page.
/// try_page(p): places the chart on page p and returns true, or returns false leaving it unchanged.
/// Returns the page index; throws StageError "<stage>: chart <chart> fits no page of width <width>"
/// when even a new page refuses the chart.
template <class Pages, class MakePage, class TryPage>
size_t place_on_pages(Pages& pages, MakePage&& make_page, TryPage&& try_page, const std::string& stage, int chart,
                      int width) {
  for (size_t p = 0;; ++p) {
    const bool fresh = p == pages.size();
    if (fresh) pages.push_back(make_page());
    if (try_page(p)) return p;
    if (fresh)
      throw StageError(stage + ": chart " + std::to_string(chart) + " fits no page of width " + std::to_string(width));
  }
}

/// Cell box size of chart c in orientation q grown by the gutter (texels).
inline int padded_w(const PackChart& c, int q, const CommonSettings& s) { return c.w[q] + s.gutter; }
inline int padded_h(const PackChart& c, int q, const CommonSettings& s) { return c.h[q] + s.gutter; }
/// Texels a block-aligned chart may need beyond its padded box to reach its block grid position
/// (block_grid - 1; 0 for other charts): page widths and max_page_size must leave it.
inline int block_slack(const PackChart& c, const CommonSettings& s) {
  return c.block_aligned && s.block_grid > 1 ? s.block_grid - 1 : 0;
}

/// Charts with faces, by decreasing padded box area (ties: chart id).
std::vector<int> order_by_area(const PackInput& in, const CommonSettings& s);

/// Trims each page to the cell boxes placed on it plus the gutter's upper half
/// (gutter - gutter / 2) and rounds the sides (round_page_side). Fills r.sizes.
void size_pages(const PackInput& in, const CommonSettings& s, PackResult& r);

/// Writes ctx.layout (pages, chart_page, wedge_uv) and the report node: pages, page_sizes,
/// packing_efficiency (chart UV area / page area), charts, exact charts, charts turned by 90/180/270,
/// charts freely rotated (the time is the framework's time_s). Wedges used by no face keep (0, 0).
void write_layout(StageContext& ctx, const PackInput& in, const PackResult& r);

/// The final texel position of base point `b` of a chart placed with `p`.
Vec2 place_point(const PackChart& c, const Placement& p, const Vec2& b);

}  // namespace texdefrag::packing
