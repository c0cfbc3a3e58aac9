// The merge engine's internals (docs/mergers.md "What one merge does"): per-chart state, the queue
// entries and the Engine whose try_merge runs one move as named steps (align, weld, free region,
// solve, acceptance checks, commit). Internal to plugins/mergers: merge_engine.h is the interface;
// this header exists so the engine's tests can run each step on a hand-built mesh.
#pragma once

#include "geometry2d.h"
#include "local_problem.h"
#include "merge_engine.h"

#include "common/planarity.h"

#include "texdefrag/core/uv_overlap.h"
#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <queue>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

namespace texdefrag::merge::detail {

/// A triangle or segment spanning more cells than this goes to its grid's `big` list instead.
constexpr long long kMaxTriCells = 64;

/// Items (faces or edges) of one chart in a uniform hash grid: cell -> item ids. Each item is
/// inserted with the cell range of its box (x0, y0, x1, y1), kept by the caller for its removal.
struct CellGrid {
  std::unordered_map<long long, std::vector<int>> cells;
  std::vector<int> big;  ///< items spanning more than kMaxTriCells cells (always tested)

  /// x in the high 32 bits, y in the low ones (unsigned shift: cells can be negative).
  static long long key(long long x, long long y) {
    return static_cast<long long>((static_cast<unsigned long long>(x) << 32) ^
                                  (static_cast<unsigned long long>(y) & 0xffffffffULL));
  }
  /// Inserts `id` over the cells of r; an item spanning too many cells goes to `big` and r becomes
  /// the empty range.
  void insert(int id, std::array<int, 4>& r);
  /// Removes `id`, inserted with range r.
  void remove(int id, const std::array<int, 4>& r);
  void clear() {
    cells.clear();
    big.clear();
  }
  /// Calls fn(id) for every item of `big` and of every cell of the ranges rs (an item can come more
  /// than once: callers de-duplicate).
  template <class Fn>
  void query(const std::vector<std::array<int, 4>>& rs, Fn&& fn) const {
    for (int id : big) fn(id);
    for (const auto& r : rs)
      for (int y = r[1]; y <= r[3]; ++y)
        for (int x = r[0]; x <= r[2]; ++x) {
          auto it = cells.find(key(x, y));
          if (it == cells.end()) continue;
          for (int id : it->second) fn(id);
        }
  }
  /// Number of cells of range r.
  static double cell_count(const std::array<int, 4>& r) {
    return (static_cast<double>(r[2]) - r[0] + 1) * (static_cast<double>(r[3]) - r[1] + 1);
  }
};

/// Counts of input charts by mirror state and turn sign (ChartInfo::groups).
using OrientationGroups = std::array<std::array<int, 3>, 2>;

struct ChartInfo {
  bool alive = true;
  bool locked = false;
  bool self_overlap = false;  ///< some of its triangles overlap (inherited from the input)
  int version = 0;
  int region = -1;
  int page = kNoPage;
  std::map<int, double> page_area;  ///< input UV area (texels^2) per input page of its faces
  double uv_area = 0;   ///< input UV area of its faces (texels^2): stable under optimisation
  double border = 0;    ///< current UV border length (texels)
  double planarity = 0; ///< cached index for the current version
  detectors::PlaneMoments mom;  ///< 3D moments of its faces (relative to the mesh's mean position)
  std::vector<int> faces;
  /// Boundary edges (face, local edge) in the order they became part of this chart; entries whose
  /// edge is no longer a boundary edge (ebnd_ == 0) are tombstones, compacted in order when they
  /// outnumber the live ones (the M-method's border sum adds the live entries in this order).
  std::vector<std::pair<int, int>> boundary;
  size_t boundary_dead = 0;
  CellGrid segs;  ///< its live boundary segments (current positions), edge ids 3f+k
  std::unordered_map<int, std::vector<int>> adj;       ///< neighbour chart -> seam edge ids
  CellGrid tris;  ///< its triangles with input UV area > 0 (current positions)
  /// Orientation as the framework's flip measure sees it (core/distortion.h): the sum over its faces
  /// of input UV area x the sign of the face's current UV turn (a face's turn is its input turn,
  /// reversed when it is laid out mirrored: the solver keeps every Jacobian's sign).
  double turn = 0;
  /// Its input charts (the framework's groups) by mirror state m (0 as input, 1 reflected) and by
  /// the sign t of their own area-weighted turn (0 negative, 1 zero, 2 positive): groups[m][t].
  OrientationGroups groups{};
};

/// Texels: a face whose input UV triangle's smallest altitude is below this is *thin*: its orientation
/// does not survive the rotation of its chart and the rounding of a float32 file (glTF texture
/// coordinates are normalised float32: half a unit in the last place is 2.4e-4 texel on an 8192 page,
/// so the altitude of a rounded triangle can be off by about 7e-4). The engine opens such faces to this
/// altitude at set-up and keeps every move from closing them below half of it (docs/mergers.md,
/// "Thin faces").
constexpr double kThinAltitude = 2e-3;
/// Whether a pair of UV triangles that overlapped by at most kCountedOverlapArea (texels^2, the
/// pipeline's overlap count, core/uv_overlap.h) as (xb, yb) overlaps by more as (x, y): the pipeline
/// would count it as a pair added. No move and no sliver opening may do that.
inline bool crosses_counted_overlap(const Tri2& xb, const Tri2& yb, const Tri2& x, const Tri2& y) {
  auto area = [](const Tri2& a, const Tri2& b) {
    return triangle_intersection_area({a.p[0], a.p[1], a.p[2]}, {b.p[0], b.p[1], b.p[2]});
  };
  return area(x, y) > kCountedOverlapArea && area(xb, yb) <= kCountedOverlapArea;
}

/// Merges the M-method's island lookahead may look ahead (its IslandLookahead(a, b, 5)).
constexpr int kIslandLookaheadSteps = 5;

struct Entry {
  double score;  ///< larger first
  int a, b;      ///< a < b
  int va, vb;    ///< chart versions when scored
  int refusal;   ///< 0 none, 1 seam_too_short, 2 alignment_error
  bool operator<(const Entry& o) const { return score < o.score; }
};

/// The merge queue: a std::priority_queue (so the same pops for the same pushes) whose entries the
/// second pass's look-ahead may read in heap order without popping them (see Engine::speculate).
struct EntryQueue : std::priority_queue<Entry> {
  const std::vector<Entry>& entries() const { return c; }
};

/// What the queue remembers of one chart pair.
struct PairState {
  int attempts = 0;
  double penalty = 1;    ///< the M-method's penalty, doubled on each rejection
  int va = -1, vb = -1;  ///< versions of the newest queue entry of this pair
  std::string last_reason;  ///< why its last attempt was refused (empty: never refused)
  // The seam's figures of the M-method's cost (score), kept while none of the seam's faces changed
  // shape or chart (Engine::fshape_ <= seam_clock), its edge list kept its length and the same chart
  // is the bigger: re-queueing every pair of a merged chart then re-scores far seams from these.
  int seam_big = -1;          ///< the bigger chart when they were computed (-1: none kept)
  size_t seam_edges = 0;      ///< seam edges then
  int seam_clock = 0;         ///< Lane::shape_clock then
  double seam_err = 0, seam_la = 0, seam_lb = 0;  ///< alignment error, UV length on a's and on b's side
};

/// The state of one merge queue and of the moves it runs: the whole atlas's (the engine's main lane),
/// or one region's in the first pass (docs/mergers.md, "Parallel first pass"). A lane touches only the
/// charts, faces and wedges of its own region, so region lanes run on threads side by side.
struct Lane {
  int region = -1;  ///< the region whose pairs this lane merges (-1: the main lane)
  EntryQueue queue;
  std::unordered_map<long long, PairState> pairs;
  static long long pair_key(int a, int b) {
    return static_cast<long long>(std::min(a, b)) << 32 | static_cast<long long>(std::max(a, b));
  }
  PairState& pair_state(int a, int b) { return pairs[pair_key(a, b)]; }
  MergeReport rep;        ///< this lane's counters (attempts, acceptances, rejections, seconds)
  double free_total = 0;  ///< sum of free-region sizes (for mean_free_vertices)
  size_t free_count = 0;
  /// Area-weighted ARAP error sum of the faces this lane answers for (the main lane: every face).
  double err_sum = 0;
  /// The global check (err_sum / weight of every face > global_bound rejects a move); else err_max.
  bool global_check = true;
  /// Without the global check, a move that would raise err_sum above this is rejected (a region's
  /// share of the budget, or infinity).
  double err_max = std::numeric_limits<double>::infinity();
  long long max_merges = 0;  ///< accepted merges after which this lane stops
  /// A first-pass lane left the adjacency of a chart outside its region unchanged (see commit_chart).
  bool stale_adjacency = false;
  /// A second-pass speculation's lane evaluated while the main lane's repair budget was spent
  /// (Engine::repair_spent of the main lane): its solves skip the injectivity repair, as the main
  /// lane's would (engine_speculate.cpp, run_batch and merge_entry).
  bool repair_off = false;
  // ---- per-move stamps and the rollback log
  int epoch = 0;       ///< stamp of the current move (per-element stamp arrays compare against it)
  int seen_stamp = 0;  ///< stamp of the current grid query
  int shape_clock = 0; ///< commits of this lane: the stamp of Engine::fshape_ (see PairState::seam_clock)
  std::vector<std::pair<int, Vec2>> saved_uv;
  std::vector<std::pair<int, std::array<int, 3>>> saved_fw;
  int saved_small = -1;
  bool saved_mirrored = false;  ///< the move reflected the smaller chart (its faces' handedness flipped)
  // ---- scratch of score() (kept to spare allocations; the queue scores every pair it pushes)
  std::vector<std::pair<int, int>> score_pairs;
  std::vector<Vec2> score_p, score_q;
};

/// Adds the move counters of `from` (attempts, acceptances, rejections, seconds) to `to`.
void add_counters(MergeReport& to, const MergeReport& from);

/// One merge attempt: what each step of try_merge hands to the next.
struct Move {
  Lane* lane = nullptr;                    ///< the lane running it (its stamps and rollback log)
  int big = -1, small = -1;                ///< the chart kept and the chart absorbed (smaller UV area)
  bool self = false;                       ///< a cut closed inside chart big (== small): begin_close
  std::vector<std::pair<int, int>> pairs;  ///< (bigger chart's wedge, smaller chart's wedge) at seam vertices
  std::vector<int> seam_edges;             ///< the seam's topology edges
  bool mirrored = false;                   ///< align: the smaller chart was reflected (improper motion)
  std::vector<int> reps;                   ///< weld: one representative wedge per welded vertex
  double dmax = 0;                         ///< weld: largest weld displacement
  std::vector<int> free_w;                 ///< free region: free wedges, nearest first
  std::vector<int> prob_faces;             ///< solve: faces of the local problem
  bool solved = false;                     ///< solve: the solver reported a usable solution
  bool repaired = false;                   ///< solve: the solver's injectivity repair ran (SolveResult)
  std::vector<int> changed;                ///< faces whose shape changed beyond the rigid motion
  std::vector<double> new_err;             ///< checks: weighted ARAP error of each changed face
  double new_sum = 0;                      ///< checks: the global weighted error sum after the move
  bool budget_checked = false;             ///< checks: the local bound held and new_sum was checked against the budget
  std::vector<int> dead;                   ///< checks: live boundary edges the weld made interior
  std::vector<int> moved_ids;              ///< checks: live boundary edges with a moved wedge
  double turn = 0;                         ///< check_orientation: the merged chart's ChartInfo::turn
  OrientationGroups groups{};              ///< check_orientation: the merged chart's ChartInfo::groups
  int fan_wedge = -1;                      ///< check_fans: the wedge whose fan was refused (-1: none)
  bool fan_welded = false;                 ///< check_fans: fan_wedge is a welded (representative) wedge
  bool hold_fans = false;                  ///< held fans: over-full boundary fans stay out of the free region
  size_t open_ends = 0;                    ///< partial weld: seam vertices left unwelded (leave_open)
  bool repaired_earlier = false;           ///< partial weld: an earlier try of the move needed the repair
  bool fill_holes = false;                 ///< hole filling: solve with triangles across the merged chart's holes
  bool holes_refused = false;              ///< hole filling: refused as fan_overlap with a hole in the problem
  bool fill_failed = false;                ///< hole filling: no hole could be triangulated (solve skipped)
};

class Engine {
 public:
  Engine(const TexturedMesh& mesh, const Topology& topo, Atlas& at, const std::vector<int>& face_region,
         const MergeOptions& opt, LocalSolver& solver)
      : mesh_(mesh), topo_(topo), at_(at), region_(face_region), opt_(opt), solver_(solver) {}

  /// The whole run: setup, the region-constrained queue, the optional second pass, compaction.
  /// Returns early, with the atlas restored, when overspent() (see first_pass).
  MergeReport run(const Progress& progress);
  /// The first pass's lanes check their regions' shares of the global distortion budget instead of
  /// checking nothing and verifying the global bound after the pass.
  void use_budget_shares() { budget_shares_ = true; }
  /// The first pass without shares ended above the global bound: the atlas was restored, run again
  /// with use_budget_shares().
  bool overspent() const { return overspent_; }
  /// Calls `f` once, on the thread running run(), when the global ARAP distortion of the run's atlas
  /// reaches `d` (checked after the first pass, after each merge the main lane accepts and after
  /// closing cuts; not in a run that ends overspent()).
  void watch_distortion(double d, std::function<void()> f) {
    watch_at_ = d;
    watch_ = std::move(f);
  }
  /// The input's charts (build_charts(mesh).atlas.face_chart: the flip groups of the closing distortion
  /// summary), when the caller has them or builds them beside the run (run_merges shares them between
  /// its engines); without, run() builds them at its end.
  void input_charts_from(std::shared_future<std::vector<int>> charts) { input_charts_ = std::move(charts); }
  /// run() throws Cancelled at its next queue entry or set-up step once *flag is true.
  void cancel_when(const std::atomic<bool>* flag) { cancel_ = flag; }
  struct Cancelled {};
  /// A first pass without regions (one lane with the global check) starts speculating (as with
  /// MergeOptions::first_pass_speculation) at its next queue entry once *flag is true: the
  /// unconstrained trial beside the run with regions, when that run has ended and left the other
  /// threads idle. The atlas is the same whenever it starts.
  void speculate_when(const std::atomic<bool>* flag) { speculate_when_ = flag; }

  // ---- the steps, public for the engine's tests (run() calls setup() first)
  /// Builds rest shapes, charts, seams and grids from the atlas (once, before any move).
  void setup();
  /// One merge of charts a and b: begin_move, align, weld, free_region, solve, check, then commit or
  /// rollback. Returns false with `reason` set (a rejection name of docs/mergers.md) when rejected.
  bool try_merge(int a, int b, std::string& reason) { return try_merge(a, b, reason, main_); }
  bool try_merge(int a, int b, std::string& reason, Lane& L);
  /// Starts a move: the bigger chart (by input UV area) keeps its id; the seam's wedge pairs.
  Move begin_move(int a, int b) { return begin_move(a, b, main_); }
  Move begin_move(int a, int b, Lane& L);
  /// Step 1: least-squares rigid motion of the smaller chart onto the bigger over the seam's wedge
  /// pairs; an improper one (with a reflection) when the smaller chart is mirrored relative to the
  /// bigger (seam_mirrored), and then its faces' rest shapes are mirrored too (face_mirrored).
  void align(Move& mv);
  /// Step 2: welds each group of paired wedges at its mean (one wedge of the bigger chart), repoints
  /// the corners and gives the smaller chart's faces the bigger chart's id.
  void weld(Move& mv);
  /// After align: whether the merged chart keeps one orientation for its reflected input charts
  /// (docs/mergers.md step 3, "Orientation"): every input chart laid out mirrored must turn like the
  /// chart's area-weighted majority, which must not be zero. Fills mv.turn and mv.groups; nullptr
  /// when it holds, else the rejection `mirror_orientation`.
  const char* check_orientation(Move& mv) const;
  /// Whether more than half of the seam edges are folded after the weld (rejected as `orientation`).
  bool seam_mostly_folded(const Move& mv) const;
  /// What follows the weld in a merge and in a closed cut alike: the fold test, free_region (and
  /// the fan rings with fan_targets), solve, the acceptance checks (timed into check_seconds), then
  /// commit, or rollback with `reason` set. Returns whether the move was committed.
  bool settle_welded(Move& mv, std::string& reason, Lane& L);
  /// try_merge without the commit: returns true with the move left in the atlas (for commit(mv) or
  /// rollback(L)), or false with `reason` set and the atlas restored.
  bool evaluate_merge(int a, int b, std::string& reason, Lane& L, Move& mv);
  /// One try of evaluate_merge with the seam vertices in `open` left unwelded (partial_weld_tries).
  /// With `fill`, the solve gets triangles across the merged chart's holes (fill_holes).
  bool attempt_merge(int a, int b, const std::vector<int>& open, bool fill, bool hold, std::string& reason, Lane& L,
                     Move& mv);
  /// Drops the seam edges touching a vertex of `open` from the move and pairs only the others' wedges.
  void leave_open(Move& mv, const std::vector<int>& open);
  /// After a fan_overlap refusal: the vertex of the refused fan when it is a welded end of the seam
  /// (one welded seam edge touches it) and another seam edge would stay welded; else -1.
  int open_seam_end(const Move& mv) const;
  /// settle_welded without the commit (same contract as evaluate_merge).
  bool evaluate_welded(Move& mv, std::string& reason, Lane& L);
  /// Whether raising lane L's error sum to new_sum breaks the budget: the global bound when
  /// L.global_check, else L.err_max (check_distortion's test; the second pass's speculation repeats it
  /// when it settles a move evaluated ahead).
  bool over_budget(const Lane& L, double new_sum) const {
    return L.global_check ? weight_sum_ > 0 && new_sum / weight_sum_ > opt_.global_bound : new_sum > L.err_max;
  }
  /// Whether lane L has spent repaired_global_share of the budget already (global check only), or is
  /// a speculation's lane with repair_off: a move whose solve needs the injectivity repair is then
  /// refused as `flip` without the repair.
  bool repair_spent(const Lane& L) const {
    return L.repair_off ||
           (L.global_check && weight_sum_ > 0 && L.err_sum / weight_sum_ > opt_.repaired_global_share * opt_.global_bound);
  }
  /// 3D length of the topology edges `edges`.
  double edges_length_3d(const std::vector<int>& edges) const;
  /// seam_price in the first pass: "price" when the move's change of the error sum, `delta`, is a
  /// larger share of the budget (global_bound x the weight of every face) than max_seam_price x the
  /// share of the input's 3D seam its seam edges make up; else nullptr (also for a closed cut).
  const char* price_refusal(const Move& mv, double delta) const;
  /// "global_distortion" when over_budget, or when the move's solve needed the injectivity repair
  /// and, under the global check, new_sum exceeds repaired_global_share of the budget; else nullptr.
  const char* budget_refusal(const Lane& L, double new_sum, bool repaired) const {
    if (over_budget(L, new_sum)) return "global_distortion";
    if (repaired && L.global_check && weight_sum_ > 0 &&
        new_sum / weight_sum_ > opt_.repaired_global_share * opt_.global_bound)
      return "global_distortion";
    return nullptr;
  }
  /// Step 3: wedges within alpha * dmax of the welded ones (Dijkstra over UV lengths), nearest first.
  void free_region(Move& mv);
  /// Step 4: solves the local problem on the free wedges and writes the result into the atlas;
  /// fills mv.prob_faces, mv.solved and mv.changed.
  void solve(Move& mv);
  /// fill_holes, inside solve (engine_holes.cpp): the boundary loop of chart c through the boundary
  /// edge (f, k), wedges in face order; false when it pinches, repeats a wedge, runs longer than the
  /// engine's bound or meets an edge already in `seen` (every edge it walks is added there).
  bool trace_boundary_loop(int f, int k, int c, std::vector<int>& loop, std::unordered_set<long long>& seen) const;
  /// fill_holes: the merged chart's hole loops through mv.prob_faces that hold a free wedge (boundary
  /// loops running against the chart's faces, i.e. every loop but the outer one).
  std::vector<std::vector<int>> hole_loops(const Move& mv) const;
  /// fill_holes: ear-clips each hole loop at the current positions and adds its triangles with a free
  /// corner to lp (rest shape: the triangle as it is, weight: its area; local_of gives a wedge's
  /// index in lp.x, adding it pinned when new). The triangles only steer the solve. Returns the
  /// number of holes that got a triangle.
  size_t add_hole_faces(const Move& mv, LocalProblem& lp, const std::function<int(int)>& local_of) const;
  /// With fan_targets, after free_region: frees the wedges around each free boundary wedge whose
  /// merged fan's input angles add up to more than a turn (up to max_free_vertices).
  void free_fan_rings(Move& mv);
  /// Held fans (mv.hold_fans, hold_full_fans option; docs/mergers.md "Held fans"): removes from
  /// mv.free_w every wedge of an over-full boundary fan (full_boundary_fan) at or next to a free
  /// wedge, and that fan's ring, welded wedges excepted. Keeps free_w's order.
  void hold_full_fans(Move& mv);
  /// Whether wedge w of chart c lies on c's boundary and its faces' input UV angles add up to at
  /// least 98% of a turn.
  bool full_boundary_fan(int w, int c) const;
  /// With fan_targets, inside solve: target shapes (inverse rest edge matrices) for the problem
  /// faces around boundary wedges whose input angles add up to more than a turn (docs/mergers.md
  /// step 6, "Fan targets").
  void fan_targets(const Move& mv, std::unordered_map<int, Mat2>& target);
  /// Step 5: the acceptance checks, cheapest first; the rejection reason, or nullptr when accepted.
  const char* check(Move& mv);
  /// Step 6: makes an accepted move permanent (distortion sums, grids, boundary, chart data, adjacency).
  void commit(Move& mv);
  /// Restores the atlas exactly as it was before the move (positions, corners, charts, handedness).
  void rollback() { rollback(main_); }
  void rollback(Lane& L);

  // ---- closing cuts inside one chart (docs/mergers.md, "Closing cuts"; engine_cuts.cpp)
  /// The cuts of chart c: its self-seam edges (manifold edges whose two textured, non-degenerate faces
  /// both lie in c but do not share wedges), split into chains at vertices where the cut branches,
  /// ends, or meets the chart's other border edges. Each chain lists its edges in path order.
  std::vector<std::vector<int>> cut_chains(int c) const;
  /// Starts a move closing `edges` (self-seam edges of chart c): the wedge pairs of the two sides.
  Move begin_close(int c, const std::vector<int>& edges, Lane& L);
  /// One closing move: weld the two UV sides of `edges` at their means, refuse (`topology`) when the
  /// chart's Euler characteristic, boundary loop count, pinched wedges or non-manifold UV edges change
  /// (it would stop being a disk: a closed surface or a cylinder cannot be flattened), then free
  /// region, solve and the acceptance checks of a merge; commit or roll back.
  bool try_close(int c, const std::vector<int>& edges, std::string& reason) { return try_close(c, edges, reason, main_); }
  bool try_close(int c, const std::vector<int>& edges, std::string& reason, Lane& L);
  /// The topology figures try_close compares: Euler characteristic V - E + F over wedges, UV edges
  /// and faces, boundary loops (components of boundary edges), wedges with more than two boundary
  /// edges (pinched), UV edges with more than two faces.
  struct CutTopology {
    long long chi = 0;
    int loops = 0, pinched = 0, nonmanifold = 0;
    bool operator==(const CutTopology& o) const {
      return chi == o.chi && loops == o.loops && pinched == o.pinched && nonmanifold == o.nonmanifold;
    }
  };
  CutTopology chart_topology(int c) const;
  /// Tries every cut of every live chart (each chain whole, then without its last or first edge when
  /// the topology refuses it), cheapest gap first, on the main lane with the global budget.
  void close_cuts(Lane& L);

  /// Whether chart `small` is mirrored relative to chart `big`: along most of their seam edges the
  /// two faces would lie on the same side of the welded edge after any proper rigid motion (their UV
  /// triangles turn the opposite way for consistently wound 3D faces).
  bool seam_mirrored(int big, int small);
  const ChartInfo& chart_info(int c) const { return charts_[static_cast<size_t>(c)]; }
  /// True when face f's UV triangle is laid out mirrored relative to its input UV triangle.
  bool face_mirrored(int f) const { return fmirror_[static_cast<size_t>(f)] != 0; }
  /// Global area-weighted ARAP distortion of the current atlas (maintained incrementally).
  double global_distortion() const { return weight_sum_ > 0 ? main_.err_sum / weight_sum_ : 0; }
  /// The main lane's counters so far (the run adds them to its report at the end).
  const MergeReport& main_counters() const { return main_.rep; }

 private:
  // ---- static data
  void setup_rest_shapes();
  /// Opens every thin face (see kThinAltitude): its solve target becomes its input triangle with the
  /// corner opposite its longest edge moved out to kThinAltitude, and in the atlas that corner's wedge
  /// is moved out likewise, or else (when that would close another face of the wedge) the wedge of
  /// either end of the longest edge (open_thin_wedge). Faces left closed are tried again, round after
  /// round, until a round opens none (a neighbouring sliver opened meanwhile may free them). Fills
  /// fthin_, thin_inv_, thin_alt_ (from the atlas after every round) and the thin-face counts.
  void open_thin_faces();
  /// open_thin_faces' change to the atlas for thin face fi: its corner k moved out from its edge
  /// (i, j), on its rest shape's side, to the height that gives the triangle the smallest altitude
  /// `alt`; kept (true) only when fi then turns as its rest shape, no other face using
  /// that wedge closes below min(its altitude before, alt) and no face of the wedge comes
  /// to overlap a triangle of `chart_faces` (fi's chart, every textured face) as a pair the pipeline
  /// would count and did not before (wedge_move_adds_overlap); else undone (false).
  bool open_thin_wedge(int fi, int i, int j, int k, const std::vector<int>& chart_faces, double alt);
  /// Rounds of open_thin_wedge (target altitude `alt` instead of kThinAltitude) over the `closed`
  /// slivers (face, i, j, k), until a round opens none; `closed` keeps those left closed.
  void open_thin_rounds(std::vector<std::array<int, 4>>& closed, std::map<int, std::vector<int>>& chart_faces,
                        double alt);
  /// Whether wedge w, moved from `old` to where it is now, makes one of `moved` (the faces of its
  /// chart using it) and a triangle of `chart_faces` (or another of `moved`) cross
  /// crosses_counted_overlap, from w at `old` to w where it is now.
  bool wedge_move_adds_overlap(int w, const Vec2& old, const std::vector<int>& moved,
                               const std::vector<int>& chart_faces) const;
  /// Smallest altitude (texels) of face f's current UV triangle, signed: negative when it turns
  /// against its rest shape (det J < 0).
  double oriented_altitude(int f) const;
  void setup_charts();
  /// Marks the input charts whose own triangles overlap (ChartInfo::self_overlap), charts side by side.
  void mark_self_overlapping_charts();
  void setup_seams_and_grids();
  int corner_of(int f, int v) const {
    const auto& fv = topo_.face_vertex[static_cast<size_t>(f)];
    for (int i = 0; i < 3; ++i)
      if (fv[static_cast<size_t>(i)] == v) return i;
    return -1;
  }
  Vec2& uv(int w) { return at_.wedge_uv[static_cast<size_t>(w)]; }
  Tri2 tri2(int f) const {
    Tri2 t;
    t.face = f;
    for (int k = 0; k < 3; ++k) {
      t.w[static_cast<size_t>(k)] = wedge(f, k);
      t.p[static_cast<size_t>(k)] = at_.wedge_uv[static_cast<size_t>(wedge(f, k))];
    }
    return t;
  }
  int wedge(int f, int k) const { return at_.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)]; }
  // note: relaxed atomic access: first-pass lanes on other threads change the charts of their own
  // faces while this lane may read them (a face around a shared vertex or across a region's border);
  // the value read never matters then (it is a chart of another region either way), but a plain
  // read would be a data race.
  int chart(int f) const { return __atomic_load_n(&at_.face_chart[static_cast<size_t>(f)], __ATOMIC_RELAXED); }
  void set_chart(int f, int c) { __atomic_store_n(&at_.face_chart[static_cast<size_t>(f)], c, __ATOMIC_RELAXED); }
  ChartInfo& C(int c) { return charts_[static_cast<size_t>(c)]; }
  Mat2 jacobian(int f) const;
  double weighted_err(int f) const;
  bool is_boundary(int f, int k, int c) const;
  double edge_uv_len(int f, int k) const;
  /// True when the faces of chart c around wedge w wrap: angle sum >= 2 pi at a boundary wedge,
  /// > 2 pi at an interior one (a single closed fan has exactly 2 pi, up to rounding).
  bool fan_overlaps(int w, int c) const;
  template <class Fn>
  void faces_of_wedge(int w, int c, Fn&& fn) const;
  /// Whether the two faces of seam edge ei lie on the same side of it in UV (a folded weld).
  bool seam_edge_folded(int ei) const;

  /// The atlas as it was before the current move of lane L (its rollback log), for the checks that
  /// count only what a move adds: face f's triangle then (corners and positions), and whether two
  /// faces of the merged chart lay in one chart then.
  struct Before {
    const Lane* lane = nullptr;
    std::unordered_map<int, Vec2> uv;
    std::unordered_map<int, std::array<int, 3>> fw;
  };
  void load_before(const Lane& L, Before& b) const;
  Tri2 tri2_before(const Before& b, int f) const;
  bool same_chart_before(const Move& mv, int f, int g) const {
    const int e = mv.lane->epoch;
    return (fsmall_[static_cast<size_t>(f)] == e) == (fsmall_[static_cast<size_t>(g)] == e);
  }
  /// Whether the overlapping pair (a, b) of the merged chart is one the move added: the faces were in
  /// two charts, or their triangles did not overlap before it, or the move makes them cross
  /// crosses_counted_overlap (the pipeline would count the pair as new).
  bool overlap_is_new(const Move& mv, Before& b, const Tri2& x, const Tri2& y) const;

  // ---- the acceptance checks (check() runs them in this order)
  const char* check_shapes(const Move& mv);
  double signed_uv_area(int f);
  int chart_orientation(int c);
  const char* check_folds(const Move& mv) const;
  const char* check_distortion(Move& mv);
  const char* check_fans(Move& mv);
  const char* check_boundary(Move& mv);
  const char* check_triangles(const Move& mv);
  // ---- check_boundary's steps
  /// Sorts the boundary edges the move can have touched (the smaller chart's, the changed faces',
  /// those around welded wedges) into mv.dead (no longer boundary) and mv.moved_ids (an end moved).
  void collect_moved_edges(Move& mv);
  /// collect_moved_edges for the three edges of face f (each edge at most once per move).
  void classify_edges(Move& mv, int f);
  /// Boundary edge e (3 x face + local edge) as a segment at its current UV positions.
  Segment edge_segment(int e);
  /// The merged chart's unmoved, live boundary segments that the moved ones can cross: the smaller
  /// chart's, and the bigger chart's near a moved segment (its segment grid, or all of them when
  /// the query would visit more cells than it has boundary edges), each once, appended to `all`.
  void gather_unmoved_segments(const Move& mv, const std::vector<Segment>& moved, std::vector<Segment>& all);
  /// Whether the crossing pair (x, y) of boundary segments is one the move added: the faces were in
  /// two charts, or the two edges did not cross before it.
  bool crossing_is_new(const Move& mv, Before& b, const Segment& x, const Segment& y) const;
  // ---- check_triangles' steps
  /// Appends the smaller chart's unchanged faces (they moved rigidly; none for a closed cut), then
  /// the changed faces, to mt, growing [lo, hi] over their corners; returns the rigid prefix's size.
  size_t collect_moved_triangles(const Move& mv, std::vector<Tri2>& mt, Vec2& lo, Vec2& hi);
  /// Appends to `rest` the bigger chart's unchanged triangles whose box meets [lo, hi], taken from
  /// its triangle grid near the triangles of mt (or from all its faces when that is cheaper).
  void gather_triangles_near(const Move& mv, const std::vector<Tri2>& mt, const Vec2& lo, const Vec2& hi,
                             std::vector<Tri2>& rest);
  /// The grid cell ranges to query for each triangle of mt (its box, widened by its longest edge);
  /// adds their cell counts to ncells.
  std::vector<std::array<int, 4>> triangle_query_cells(const std::vector<Tri2>& mt, double& ncells) const;
  // ---- commit parts
  void commit_grids(const Move& mv);
  void commit_boundary(const Move& mv);
  void commit_chart(const Move& mv);

  // ---- queue
  void refresh_planarity(int c);
  /// After lane L committed a move of chart big whose rollback log is in `log` (L itself, or a
  /// speculation's lane): stamps every face whose corners moved or were repointed with ++L.shape_clock.
  void mark_shapes(Lane& L, const Lane& log, int big);
  /// The seam figures of the M-method's cost for charts a and b (a < b; big the one fitted onto):
  /// the mean distance of the seam's wedge pairs after the rigid fit, and its UV length on a's and b's side.
  void seam_figures(Lane& L, int a, int big, int small, double& err, double& la, double& lb);
  /// Whether ps's kept seam figures still hold for the seam `seam` with `big` the bigger chart.
  bool seam_current(const PairState& ps, int big, const std::vector<int>& seam) const;
  void push_pair(Lane& L, int a, int b);
  double score(Lane& L, int a, int b, int& refusal);
  /// The M-method's exception to its short-seam refusal: true when a sequence of at most max_steps
  /// merges involving a and b can close a UV island, i.e. for some neighbour c of a or b, the charts
  /// reachable from a without passing through c are found within max_steps pushes of a depth-first
  /// visit (so they form an island whose only neighbour is c). False at once when a or b has more
  /// than max_steps neighbours.
  bool island_lookahead(int a, int b, int max_steps) const;
  bool candidate(int a, int b) const;
  void pair_points(int big, int small, std::vector<std::pair<int, int>>& pairs);
  /// pair_points over the given seam edges only (edges between chart big and one other chart).
  void seam_pairs(int big, const std::vector<int>& edges, std::vector<std::pair<int, int>>& pairs);
  void drain(Lane& L, const Progress& progress, double base, double span);
  /// The region-constrained first pass: one lane per region, run on the thread pool when the solver
  /// allows it, combined in region order (the result does not depend on the thread count).
  void first_pass(const Progress& progress, double span);
  std::vector<Lane> make_region_lanes();
  void run_lanes(std::vector<Lane>& lanes, const Progress& progress, double span);
  void join_lanes(std::vector<Lane>& lanes);
  /// Rebuilds every chart's seam adjacency from the seam edges (after lanes left some stale).
  /// Calls fn(edge index, edge, face x, face y, chart of x, chart of y) for every manifold edge
  /// (two faces, two distinct vertices) between two textured, non-degenerate faces, in edge order:
  /// the edges a seam can lie on, whether its charts differ or not.
  template <class Fn>
  void for_each_textured_edge(Fn&& fn) const;
  void rebuild_adjacency();
  void start_second_pass(double local_bound);

  // ---- the second pass side by side (docs/mergers.md, "Parallel second pass"; engine_speculate.cpp)
  /// A queue entry evaluated ahead of its turn on a lane of its own, on the atlas as it was then
  /// (with other entries' evaluations of disjoint charts in it).
  struct Speculation {
    Entry e{};
    Lane lane;           ///< its stamps, rollback log and counters
    Move mv;             ///< the evaluated move (mv.new_sum: the move's change of the error sum)
    std::string reason;  ///< the first check that refused it (empty: it passed every check it ran)
    bool live = false;   ///< its result stands: its charts are still at versions e.va, e.vb
    bool in_atlas = false;  ///< it passed: its move is in the atlas until settled or dropped
  };
  /// What try_merge(e.a, e.b, reason, L) does, for an entry drain popped: with speculation on (the
  /// second pass or the first pass's only lane, spec_width_ > 1), a live speculation of e is settled, else e is evaluated in a batch
  /// with up to spec_width_ - 1 entries further down the queue (speculations), side by side.
  /// `log`: the lane whose rollback log holds the move (for mark_shapes).
  bool merge_entry(const Entry& e, std::string& reason, Lane& L, const Lane*& log);
  /// Speculation starts on a lane that drains alone and checks the global budget: the main lane in
  /// the second pass, or the first pass's only lane (solo_lane_); other lanes never speculate.
  void start_speculation(Lane& L);
  void stop_speculation(Lane& L);
  /// Evaluates the batch's entries side by side, each on its slot's lane (batch[0]: the entry drain
  /// popped, on the calling thread).
  void run_batch(std::vector<Speculation*>& batch);
  /// Fills batch: a slot for e, then slots for entries further down the queue (see the file's note).
  void pick_lookahead(const Entry& e, std::vector<Speculation*>& batch);
  Speculation* free_slot();
  bool settle(Speculation& s, std::string& reason, Lane& L);
  /// Whether speculation s, evaluated with its lane's repair_off, was refused for inverted triangles
  /// that L would now repair (L's error sum fell back under the repair share since): then s cannot
  /// stand for L's evaluation. Also whether an earlier partial-weld try of s's move needed the
  /// repair that L has spent since (L would have stopped at that try).
  bool repair_skipped_wrongly(const Speculation& s, const Lane& L) const;
  void drop(Speculation& s);
  /// Drops the speculations of charts a or b: every one, or (in_atlas_only) those whose move is in
  /// the atlas (before drain scores a pair of them, which reads their UVs).
  void drop_speculations_of(int a, int b, bool in_atlas_only);
  /// Whether chart x is y or a neighbour of it.
  bool near_chart(int x, int y) const {
    return x == y || charts_[static_cast<size_t>(x)].adj.count(y) != 0;
  }
  class BatchPool;
  struct DeletePool {
    void operator()(BatchPool* p) const;  // (engine_speculate.cpp, where BatchPool is complete)
  };
  std::unique_ptr<BatchPool, DeletePool> pool_;  ///< the threads of run_batch (while speculating_)
  std::vector<std::unique_ptr<Speculation>> spec_;  ///< slots (live or free)

  int spec_width_ = 1;       ///< entries evaluated per batch
  bool speculating_ = false; ///< drain runs spec_lane_ with speculation
  Lane* spec_lane_ = nullptr;  ///< the lane speculating (while speculating_): main_, or the first pass's only lane
  /// The first pass's only lane while it drains (it checks the global budget, like the main lane):
  /// it may speculate (start_speculation).
  const Lane* solo_lane_ = nullptr;
  const std::atomic<bool>* speculate_when_ = nullptr;  ///< speculate_when's flag
  /// The solo lane waits for *speculate_when_ to speculate (drain starts it then).
  bool speculation_pending_ = false;
  int stamp_high_ = 0;       ///< the highest epoch or seen stamp any lane used so far
  /// Fills rep_.seam_left: the seams still cut when the engine stops, by why they are (docs/mergers.md
  /// step 9): each adjacent chart pair's 3D seam length under its last refusal reason.
  void measure_seams_left();

  const TexturedMesh& mesh_;
  const Topology& topo_;
  Atlas& at_;
  const std::vector<int>& region_;
  MergeOptions opt_;   ///< priority and local_bound switch to the second pass's values when it starts
  bool across_ = false;  ///< second pass: regions are ignored
  bool price_on_ = false;     ///< first pass with seam_price: moves are refused as `price` (price_refusal)
  double seam_in_3d_ = 0;     ///< seam_price: 3D length of the seam between the input's charts
  bool budget_shares_ = false;  ///< first-pass lanes check their share of the budget (use_budget_shares)
  bool overspent_ = false;      ///< see overspent()
  double watch_at_ = 0;                  ///< watch_distortion's level
  std::function<void()> watch_;          ///< watch_distortion's call (empty once made)
  const std::atomic<bool>* cancel_ = nullptr;  ///< cancel_when's flag
  std::shared_future<std::vector<int>> input_charts_;  ///< input_charts_from's (none: run() builds them)
  /// Calls watch_ when the main lane's error sum reached watch_at_ (on run()'s thread only).
  void check_watch();
  /// Throws Cancelled when *cancel_ (any thread).
  void check_cancel() const {
    if (cancel_ && cancel_->load(std::memory_order_relaxed)) throw Cancelled{};
  }
  LocalSolver& solver_;
  MergeReport rep_;  ///< the run's report (lanes' counters are added to it)
  Lane main_;        ///< the main lane (the second pass; the engine's tests)

  std::vector<int> vf_off_, vf_;       ///< welded vertex -> textured faces (CSR)
  std::vector<Mat2> rest_inv_;         ///< inverse rest edge matrix (input UV triangle, texels; mirrored y -> -y when fmirror_)
  std::vector<char> fmirror_;          ///< face laid out mirrored relative to its input UV triangle
  std::vector<double> rest_w_;         ///< input UV area (0: no energy)
  std::vector<char> fthin_;            ///< thin face (open_thin_faces)
  std::unordered_map<int, Mat2> thin_inv_;   ///< thin faces' solve targets (inverse opened rest edge matrix; mirrored with the face)
  std::unordered_map<int, double> thin_alt_; ///< altitude (texels) no move may close a thin face below
  std::vector<double> err_w_;          ///< weight * ARAP error, per face, current atlas
  double weight_sum_ = 0;
  std::vector<Vec3> region_normal_;
  std::vector<ChartInfo> charts_;
  std::vector<double> refreshed_area_;  ///< uv_area of a chart when all its pairs were last re-pushed

  // ---- per-move scratch with epoch stamps (Lane::epoch; each element is only stamped by its region's lane)
  std::vector<int> wstamp_, wmoved_, wrep_, wvisit_, wdone_, wfan_, fstamp_, fchanged_;
  std::vector<int> fsmall_;  ///< face was in the move's smaller chart (stamp Lane::epoch)
  std::vector<int> fshape_;  ///< Lane::shape_clock of the last commit that moved or repointed a corner of face f
  std::vector<double> wdist_;
  std::vector<int> wlocal_, wlocal_stamp_;  ///< solve: local index of a wedge in the problem, its stamp
  // ---- per-chart triangle grids (cell size tri_cell_, shared by all charts)
  double tri_cell_ = 1;
  std::vector<int> fowner_;                 ///< chart whose grid holds face f (-1: none)
  std::vector<std::array<int, 4>> fcells_;  ///< cell range x0, y0, x1, y1 it was inserted with
  std::vector<int> fseen_;                  ///< query stamps
  void tri_box(int f, Vec2& lo, Vec2& hi) const {
    lo = hi = at_.wedge_uv[static_cast<size_t>(wedge(f, 0))];
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(at_.wedge_uv[static_cast<size_t>(wedge(f, k))]);
      hi = hi.cwiseMax(at_.wedge_uv[static_cast<size_t>(wedge(f, k))]);
    }
  }
  int cell_of(double x) const {
    const double q = std::floor(x / tri_cell_);
    return static_cast<int>(std::max(-1e9, std::min(1e9, q)));
  }
  /// Cell range of a grid query for the box [lo, hi] of an item of size len, widened by more than
  /// the overlap tests' touching tolerance (1e-7 x the longest edge of a pair).
  std::array<int, 4> query_cells(const Vec2& lo, const Vec2& hi, double len) const {
    const double margin = 1e-6 * len + 1e-4 * tri_cell_;
    return {cell_of(lo.x() - margin), cell_of(lo.y() - margin), cell_of(hi.x() + margin), cell_of(hi.y() + margin)};
  }
  void grid_insert(int c, int f);
  void grid_remove(int f);
  // ---- per-chart boundary-segment grids (same cells as the triangle grids); edge id e = 3f + k
  std::vector<char> ebnd_;                  ///< edge e is a live boundary edge of chart(f)
  std::vector<int> eowner_;                 ///< chart whose segment grid holds edge e (-1: none)
  std::vector<std::array<int, 4>> ecells_;  ///< cell range it was inserted with
  std::vector<int> edead_, emoved_, eseen_; ///< per-move stamps (Lane::epoch, Lane::seen_stamp)
  void seg_insert(int c, int e);
  void seg_remove(int e);
  void compact_boundary(ChartInfo& ch);
  /// Flips the handedness of `faces`: rest shapes mirrored y -> -y (rest_inv_ times diag(1, -1)).
  void mirror_faces(const std::vector<int>& faces);
  /// Logs wedge w's position in L's rollback log (once per move).
  void save_uv(Lane& L, int w) {
    if (wstamp_[static_cast<size_t>(w)] == L.epoch) return;
    wstamp_[static_cast<size_t>(w)] = L.epoch;
    L.saved_uv.emplace_back(w, uv(w));
  }
};

template <class Fn>
void Engine::faces_of_wedge(int w, int c, Fn&& fn) const {
  const int v = at_.wedge_vertex[static_cast<size_t>(w)];
  for (int i = vf_off_[static_cast<size_t>(v)]; i < vf_off_[static_cast<size_t>(v) + 1]; ++i) {
    const int f = vf_[static_cast<size_t>(i)];
    if (chart(f) != c) continue;
    for (int k = 0; k < 3; ++k)
      if (wedge(f, k) == w) {
        fn(f, k);
        break;
      }
  }
}

}  // namespace texdefrag::merge::detail
