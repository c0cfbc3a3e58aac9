// The seam-merging engine shared by mergers.optcuts and mergers.arap (Liu et al. 2024, section 2.2;
// Maggiordomo et al. 2021 for the M-method's cost and acceptance tests). docs/mergers.md describes
// every rule; in short:
// - candidates: chart pairs sharing seam edges (manifold edges between two textured faces whose
//   corners do not share wedges), both charts in the same region (a chart's region is the majority
//   region of its faces) and, unless cross_page, on the same input page; charts with a degenerate
//   face are locked. A merged chart's atlas.chart_page is the page holding most of its input UV area.
// - order: a max-priority queue on X = max(I_a, I_b) * max(UVArea_a, UVArea_b) (planarity), or the
//   M-method's cost (smallest first); stale entries are skipped via per-chart version stamps.
// - one move: rigid least-squares fit of the smaller chart onto the bigger over the seam's wedge
//   pairs, weld each pair at its midpoint, free the wedges within alpha * (largest weld
//   displacement) of the seam (Dijkstra over UV edge lengths in the merged chart), optimise them
//   against the input UV triangles with the LocalSolver, then accept or roll back exactly.
#pragma once

#include "local_problem.h"

#include "common/planarity.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/stage/options.h"
#include "texdefrag/stage/stage.h"

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace texdefrag::merge {

enum class Priority {
  Planarity,  ///< Liu et al.: largest max(I_a, I_b) * max(area_a, area_b) first
  MMethod,    ///< Maggiordomo et al.: smallest err * min(B/L) * min(area) * penalty first, with refusals
};

/// The seam price of the first pass (MergeOptions::seam_price; docs/mergers.md, "Seam price").
enum class SeamPrice {
  Off,   ///< no price
  On,    ///< first-pass merges are priced
  Both,  ///< the whole merging runs twice, without and with the price; the atlas leaving less seam is kept
};

/// What happens after the region-constrained queue is empty.
enum class SecondPass {
  None,           ///< stop (the paper's behaviour)
  AcrossRegions,  ///< queue every adjacent chart pair, regions ignored, and merge on with the remaining budget
};

struct MergeOptions {
  Priority priority = Priority::Planarity;  ///< merge order
  /// The M-method's alignment refusal scales with the seam's mean UV edge length (true, before 2026-12-02) instead of its whole
  /// UV length (the program's rule; docs/mergers.md step 2).
  bool alignment_per_edge = false;
  double alpha = 5;             ///< free-region radius as a multiple of the largest weld displacement
  double global_bound = 0.025;  ///< reject when the global area-weighted ARAP distortion exceeds this
  double local_bound = 0.5;     ///< reject when the free region's area-weighted ARAP error exceeds this
  double min_singular_value = 0;  ///< reject when a reshaped triangle's smaller singular value is below this (0: off)
  /// A move whose solve needed the injectivity repair (SolveResult::repaired) is refused as
  /// `local_distortion` above this in a lane without the global check (the first pass with regions),
  /// and as `global_distortion` when the global distortion after it exceeds repaired_global_share x
  /// global_bound (docs/mergers.md step 7).
  double repaired_local_bound = 0.025;
  double repaired_global_share = 0.5;
  /// On: in the first pass, a move whose share of the distortion budget (its change of the error sum
  /// over global_bound x the weight of every face) exceeds max_seam_price x its share of the input's
  /// seam (its 3D seam length over the input's) is refused as `price`; the second pass has no such
  /// limit. Where the budget binds, it goes to the merges that weld the most seam for it. Both: the
  /// whole merging without and with the price, the atlas leaving less 3D seam kept (docs/mergers.md,
  /// "Seam price").
  SeamPrice seam_price = SeamPrice::Off;
  double max_seam_price = 5;  ///< > 0: see seam_price
  /// Models with more faces merge once, without the price, whatever seam_price says when it is Both:
  /// the two runs double the merger's time and hold one more atlas (the 100k-face synthetic factory:
  /// merger wall 6.9 -> 14.6 s, peak 183 -> 229 MiB), which the 1M-face one cannot afford (1 GB).
  size_t seam_price_both_max_faces = 300000;
  long long max_merges = 100000000;  ///< stop after this many accepted merges (>= 0)
  int max_attempts = 3;         ///< attempts per chart pair (a rejected pair is retried when a chart changes)
  int max_free_vertices = 2000; ///< cap on the free region (nearest wedges first)
  bool cross_page = true;       ///< allow merging charts whose texels lie on different input pages
  detectors::CpiWeights weights;  ///< planarity index weights (detectors/common/planarity.h)
  SecondPass second_pass = SecondPass::None;          ///< merging across regions after the first queue
  Priority second_pass_priority = Priority::MMethod;  ///< order of the second pass
  double second_pass_local_bound = 0.5;  ///< local_bound during the (last step of the) second pass
  bool second_pass_seam_refusal = true;  ///< keep the M-method's seam_too_short refusal in the second pass
  int second_pass_steps = 1;  ///< second-pass steps, local bounds second_pass_local_bound / 2^(steps-1) ... x 1
  /// After the last pass, close cuts inside charts (weld the two UV sides of self-seams) where the
  /// chart stays a disk and the checks of a merge hold (docs/mergers.md, "Closing cuts").
  bool close_cuts = false;
  /// With regions: when the run ends below unconstrained_trial_share x global_bound (the budget the
  /// regions allocate was not binding), merge again from the input without regions and keep that
  /// atlas when it leaves a shorter 3D seam (docs/mergers.md, "Unconstrained trial").
  bool unconstrained_trial = false;
  double unconstrained_trial_share = 0.8;  ///< [0, 1]: share of global_bound under which the trial runs
  /// The trial's min_singular_value (its collapse refusal); negative = min_singular_value's. The trial runs
  /// where the regions left the budget unspent, so collapsed-triangle refusals there mostly keep
  /// seams cut rather than save budget (docs/mergers.md, "The trial's collapse limit").
  double unconstrained_trial_min_singular_value = -1;
  /// The trial's max_attempts, repaired_global_share and second_pass_local_bound; 0 / negative =
  /// the run's own. Like the collapse limit, they act only where the regions left the budget
  /// unspent, and the trial is kept only when it leaves less seam (docs/mergers.md, "The trial's
  /// own limits").
  int unconstrained_trial_max_attempts = 0;
  /// The unconstrained trial of a priced run (seam_price on, or the priced half of both) prices its
  /// first pass too only with this (docs/mergers.md, "Seam price": better on the urban tiles, worse on
  /// the Cedar Creek rooms, hence both).
  bool unconstrained_trial_seam_price = false;
  double unconstrained_trial_repaired_global_share = -1;
  double unconstrained_trial_second_pass_local_bound = -1;
  /// With two threads or more the trial starts on a thread of its own beside the run with regions and
  /// is dropped when that run's distortion reaches the share (same atlas, less wall time, two engines in
  /// memory); false runs it after that run.
  bool unconstrained_trial_beside = true;
  /// Models with more faces run the trial after the run with regions whatever unconstrained_trial_beside
  /// says: two engines are never held at once above this size (docs/speed.md, "The unconstrained trial beside").
  size_t unconstrained_trial_beside_max_faces = 300000;
  /// Solve with target shapes that close over-full boundary fans (docs/mergers.md step 6).
  bool fan_targets = false;
  double fan_margin = 0.01;  ///< fan targets close at 2 pi (1 - fan_margin)
  /// A move refused as fan_overlap at a welded seam end is tried again with that seam vertex left
  /// unwelded (its seam edge stays cut), up to this many times per move; 0 = never (docs/mergers.md
  /// step 7, "Partial welds").
  int partial_weld_tries = 0;
  /// A move refused as fan_overlap whose local problem touches a hole of the merged chart is tried
  /// again with temporary triangles across its holes (docs/mergers.md, "Hole filling").
  bool fill_holes = false;
  /// A move refused as fan_overlap at a wedge it did not weld is tried again with every boundary fan
  /// of the free region whose input UV angles add up to a turn or more (within 2%) held where it is:
  /// the fan's wedge and its one ring leave the free region (docs/mergers.md, "Held fans").
  bool hold_full_fans = false;
  /// Queue entries the second pass (and a speculating first pass, below) evaluates side by side
  /// (docs/mergers.md, "Parallel second pass"):
  /// 0 = twice thread_count() (1 with one thread), 1 = one at a time. Not a stage option (the result is the same for any
  /// value); tests set it to run the speculation on one thread.
  int second_pass_batch = 0;
  /// A first pass whose candidate pairs all lie in one lane (no regions) speculates as the second
  /// pass does. Not a stage option (same result either way): set by the unconstrained trial when it
  /// runs alone after the run with regions (models above unconstrained_trial_beside_max_faces), where
  /// its moves are many; off elsewhere, since handing 0.1-0.2 ms moves between two busy cores cost
  /// more than it saved (mmethod.json on t016_L18: merger wall 0.60 -> 0.65 s, CPU +35%).
  bool first_pass_speculation = false;
  /// Tests: every time score() re-uses a seam's kept figures (PairState::seam_err), compute them
  /// again and throw std::logic_error when they differ.
  bool check_kept_seams = false;
};

/// The option declarations shared by every merger built on the engine (name, default, range, help).
/// @param local_bound_default  default of `local_bound` (the M-method's 0.5; mergers.optcuts uses a
///                             tighter one, see docs/mergers.md)
std::vector<OptionSpec> merge_option_specs(double local_bound_default = 0.5);
/// Reads the shared options (declared by merge_option_specs) from validated stage options.
MergeOptions merge_options_from(const Options& o);

/// Counters of one run; written to the stage's report node by to_json().
struct MergeReport {
  size_t charts_in = 0, charts_out = 0;
  size_t locked_charts = 0;           ///< charts never merged (degenerate faces)
  size_t self_overlapping_charts = 0; ///< input charts whose own triangles overlap (checked by triangles)
  size_t candidates_initial = 0;      ///< candidate chart pairs at the start
  size_t attempted = 0, accepted = 0;
  size_t charts_after_first_pass = 0;  ///< live charts when the region-constrained queue emptied
  size_t accepted_second_pass = 0;     ///< merges accepted by the cross-region pass
  size_t attempted_second_pass = 0;    ///< merges attempted by the cross-region pass (solved or refused before)
  size_t accepted_mirrored = 0;        ///< accepted merges that reflected the smaller chart
  size_t mirrored_faces_out = 0;       ///< faces laid out as a mirror image of their input UV triangle
  double distortion_after_first_pass = 0;  ///< global ARAP distortion at that moment
  /// The first pass ran again with per-region budget shares (docs/mergers.md, "Parallel first pass"):
  /// without them it ended above global_bound.
  bool first_pass_budget_shares = false;
  size_t first_pass_lanes = 0;  ///< regions with candidate pairs: the first pass's independent queues
  /// Unconstrained trial (unconstrained_trial): whether it ran and whether its atlas was kept, and the
  /// 3D seam length the run with regions left cut (seam_left_length_3d of the kept run is the other).
  bool unconstrained_trial_run = false, unconstrained_trial_kept = false;
  double regions_seam_left_length_3d = 0;
  /// seam_price = both: the priced run's atlas was kept; the 3D seam the unpriced run left cut.
  bool seam_price_kept = false;
  double unpriced_seam_left_length_3d = 0;
  /// The trial on a thread beside the run with regions (two threads or more): "ended" (it ran to its
  /// end), "dropped" (stopped when that run's distortion reached the trial's share), or "off".
  std::string unconstrained_trial_beside = "off";
  double first_pass_seconds = 0;   ///< wall time of the first pass (its lanes run side by side)
  double second_pass_seconds = 0;  ///< wall time of the second pass (one queue)
  double close_cuts_seconds = 0;   ///< wall time of closing cuts (close_cuts)
  /// First-pass moves evaluated ahead of their turn, side by side (only when one lane holds every
  /// candidate pair, e.g. the unconstrained trial's first pass), and of them those used.
  size_t first_pass_speculated = 0, first_pass_speculation_used = 0;
  size_t second_pass_speculated = 0;  ///< second-pass moves evaluated ahead of their turn, side by side
  size_t second_pass_speculation_used = 0;  ///< of them, used when their turn came (the rest were dropped)
  /// CPU time of the second pass (every thread), and of it the CPU time of moves evaluated beside
  /// each batch's longest one: on free cores the pass would take about the difference.
  double second_pass_cpu_seconds = 0, second_pass_side_cpu_seconds = 0;
  size_t seam_figures_kept = 0;  ///< pairs re-scored from their seam's kept figures (M-method order)
  std::map<std::string, size_t> rejected;  ///< by reason
  size_t fan_target_moves = 0;   ///< moves whose solve used fan targets (fan_targets)
  /// Injectivity repair (mergers.arap's `untangle`): solves that ended with inverted triangles and
  /// were repaired, of those the ones left without any, and the moves then accepted.
  size_t repairs_tried = 0, repairs_untangled = 0, repairs_accepted = 0;
  /// partial_weld_tries: moves tried again with a seam end left unwelded, and the moves accepted so.
  size_t partial_weld_retries = 0, partial_welds_accepted = 0;
  /// fill_holes: moves tried again with triangles across their holes (after a fan_overlap refusal),
  /// those then accepted, and the holes given triangles, summed over those solves.
  size_t hole_fill_retries = 0, hole_fills_accepted = 0, holes_filled = 0;
  /// hold_full_fans: moves tried again with their over-full boundary fans held, and those then accepted.
  size_t fan_hold_retries = 0, fan_holds_accepted = 0;
  size_t cut_edges_in = 0;       ///< self-seam edges (both sides in one chart) when closing started
  size_t cuts_attempted = 0;     ///< closing moves tried (close_cuts)
  size_t cuts_closed = 0;        ///< closing moves accepted
  size_t cut_edges_closed = 0;   ///< self-seam edges they welded
  std::map<std::string, size_t> cut_rejected;  ///< closing moves refused, by reason (`topology` or a merge's)
  /// Seams left cut at the end, by the reason they are (docs/mergers.md step 9): the last refusal of
  /// the chart pair (a rejection name), `not_candidate` (locked, no region or another page),
  /// `never_attempted`, or `cut` (a seam inside one chart closing cuts did not close). Per reason:
  /// seam edges and their 3D length.
  struct SeamLeft {
    size_t pairs = 0, edges = 0;
    double length_3d = 0;
  };
  std::map<std::string, SeamLeft> seam_left;
  /// Total 3D length of seam_left.
  double seam_left_length_3d() const {
    double t = 0;
    for (const auto& kv : seam_left) t += kv.second.length_3d;
    return t;
  }
  /// Faces whose input UV triangle is thinner than the engine's kThinAltitude (a float32 file cannot
  /// orient them once turned), and those the set-up opened to it (docs/mergers.md, "Thin faces").
  size_t thin_faces = 0, thin_faces_opened = 0;
  double distortion_in = 0;           ///< global ARAP distortion of the atlas given to the engine
  double distortion_out = 0;          ///< after merging (recomputed from scratch)
  size_t flipped_out = 0;             ///< faces with det J <= 0 after merging (must be 0)
  double optimisation_seconds = 0;    ///< time inside the LocalSolver
  double check_seconds = 0;           ///< time in the acceptance tests
  double mean_free_vertices = 0;      ///< mean free-region size over attempts that reached the solver
  json to_json() const;
};

/// Progress callback (fraction in [0, 1]); may throw to cancel.
using Progress = std::function<void(double)>;

/// Merges charts of `atlas` in place and compacts it. `face_region` may be empty (one region).
/// @param mesh         the input mesh (rest shapes = its corner texels); page sizes must be known
/// @param topo         topology of mesh
/// @param atlas        working atlas (texels); on return merged and compacted
/// @param face_region  region per face (-1 = none) or empty for a single region
/// @param opt          engine options
/// @param solver       the local optimiser
/// @param progress     progress callback, may be empty
MergeReport run_merges(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas,
                       const std::vector<int>& face_region, const MergeOptions& opt, LocalSolver& solver,
                       const Progress& progress);

/// Runs the engine as a Merger stage: reads ctx.mesh, ctx.topology, ctx.regions, changes ctx.atlas,
/// reports progress as `stage` and writes MergeReport::to_json() into *ctx.report.
/// Throws StageError("STAGE: cause") when the context lacks mesh/topology or the regions do not
/// match the mesh.
/// @param ctx     stage context (mesh, topology and atlas required; regions may be empty)
/// @param stage   qualified stage name, e.g. "mergers.optcuts" (error prefix and progress label)
/// @param opt     engine options
/// @param solver  the local optimiser
void run_merge_stage(StageContext& ctx, const std::string& stage, const MergeOptions& opt, LocalSolver& solver);

}  // namespace texdefrag::merge
