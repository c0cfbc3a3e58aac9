// Seam merging with exact rollback: Liu et al. 2024, "Planar feature-preserving texture
// defragmentation method for 3D urban building models" (Remote Sensing 16(22) 4154), section 2.2
// (merge order, rigid alignment, weld, local optimisation within alpha * displacement, whole-seam
// acceptance), and Maggiordomo, Cignoni, Tarini 2021, "Texture defragmentation for
// photo-reconstructed 3D models" (the M-method's cost, refusals and acceptance tests).
#include "merge_engine.h"

#include "engine_internal.h"

#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <functional>
#include <future>
#include <iterator>
#include <limits>
#include <cmath>
#include <mutex>
#include <numeric>
#include <optional>
#include <queue>
#include <thread>
#include <unordered_map>

namespace texdefrag::merge {

namespace {
/// Options of the merge order, the distortion bounds and the free region.
std::vector<OptionSpec> order_and_bound_specs(double local_bound_default) {
  return {
      opt_enum("priority", "planarity", {"planarity", "mmethod"},
               "Merge order: 'planarity' = largest max(I_a,I_b)*max(area_a,area_b) first (Liu et al.); "
               "'mmethod' = smallest alignment-error cost first, with the M-method's refusals and penalty doubling"),
      opt_enum("alignment_scale", "seam", {"seam", "edge"},
               "Under the 'mmethod' order, refuse a pair (alignment_error) when the mean distance between the seam's "
               "paired wedges after the rigid fit exceeds 2 x this length: 'seam' = the seam's UV length (mean of its "
               "two sides; the M-method program's rule), 'edge' = the seam's mean UV edge length (stricter by the "
               "seam's edge count; before 2026-12-02)"),
      opt_double("alpha", 5, "Free-region radius as a multiple of the largest weld displacement").range(0, 1000),
      opt_double("global_bound", 0.025,
                 "Reject a merge when the area-weighted ARAP distortion over all textured faces exceeds this")
          .range(0, 1e6),
      opt_double("local_bound", local_bound_default,
                 "Reject a merge when the area-weighted ARAP error of its free region exceeds this")
          .range(0, 1e6),
      opt_double("min_singular_value", 0,
                 "Reject a merge when a reshaped triangle's smaller singular value (output UV size over input UV size "
                 "along its most compressed direction) falls below this: no near-collapsed, smeared triangles (0: off, "
                 "the M-method's and the paper's behaviour)")
          .range(0, 1),
      opt_double("repaired_local_bound", 0.025,
                 "Where the global bound is not checked per move (the first pass with regions), reject a merge whose "
                 "solve needed the injectivity repair (mergers.arap's untangle) when its free region's ARAP error "
                 "exceeds this")
          .range(0, 1e6),
      opt_double("repaired_global_share", 0.5,
                 "Reject a merge whose solve needed the injectivity repair when the global ARAP distortion after it "
                 "exceeds this share of global_bound")
          .range(0, 1),
      opt_enum("seam_price", "off", {"off", "on", "both"},
               "'on': in the first pass, refuse (price) a merge whose share of the distortion budget exceeds "
               "max_seam_price times its share of the input's 3D seam length (the second pass has no such limit); "
               "'both': merge without and with the price and keep the atlas that leaves less 3D seam; 'off': no price"),
      opt_int("seam_price_both_max_faces", 300000,
              "Models with more faces than this merge once, without the price, when seam_price is 'both' (the two "
              "runs double the merger's time and hold one more atlas)")
          .at_least(0),
      opt_double("max_seam_price", 5,
                 "With seam_price: the largest share of the distortion budget a first-pass merge may spend per share "
                 "of the input's 3D seam length it welds")
          .range(1e-6, 1e6),
      opt_int("max_merges", 100000000, "Stop after this many accepted merges").at_least(0),
      opt_int("max_attempts", 3,
              "Attempts per chart pair; a rejected pair is retried only after one of its charts changed")
          .range(1, 1000),
      opt_int("max_free_vertices", 2000, "Largest free region of one merge (nearest wedges to the seam first)")
          .range(1, 10000000)
  };
}

/// Options of the second pass (across regions) and of closing cuts.
std::vector<OptionSpec> second_pass_specs() {
  return {
      opt_enum("second_pass", "none", {"none", "across_regions"},
               "After the region-constrained queue is empty: 'none' stops (Liu et al.); 'across_regions' queues every "
               "adjacent chart pair, regions ignored, and merges on with the remaining global distortion budget"),
      opt_enum("second_pass_priority", "mmethod", {"planarity", "mmethod"},
               "Merge order of the second pass (see 'priority')"),
      opt_double("second_pass_local_bound", 0.5,
                 "local_bound during the second pass (area-weighted ARAP error of the free region)")
          .range(0, 1e6),
      opt_bool("second_pass_seam_refusal", true,
               "Under the 'mmethod' order in the second pass, refuse seams shorter than 0.2 of both charts' borders "
               "(the M-method's rule); false tries them too"),
      opt_int("second_pass_steps", 1,
              "The second pass runs this many times with local bounds second_pass_local_bound / 2^(steps-1), ..., / 2, "
              "x 1 (cheap merges first); attempts are reset between steps")
          .range(1, 20),
      opt_bool("close_cuts", false,
               "After the last pass, close cuts inside one chart (weld the two UV sides of a self-seam) when the "
               "chart stays a disk and the merge checks (flips, folds, fans, overlaps, local and global distortion) "
               "hold")
  };
}

/// Options of the unconstrained trial, fan targets, partial welds and cross-page merges.
std::vector<OptionSpec> trial_and_weld_specs() {
  return {
      opt_bool("unconstrained_trial", false,
               "With regions: when the run ends below unconstrained_trial_share x global_bound (the regions had no "
               "scarce budget to allocate), merge again from the input without regions and keep that atlas when it "
               "leaves a shorter 3D seam"),
      opt_bool("unconstrained_trial_beside", true,
               "With two threads or more, start the unconstrained trial on a thread of its own beside the run with "
               "regions and drop it as soon as that run's distortion reaches unconstrained_trial_share x global_bound "
               "(same atlas; the merger's wall time falls where the trial is kept, its memory holds two engines: the "
               "1M-face synthetic factory 923 -> 1452 MiB); false runs it after that run"),
      opt_int("unconstrained_trial_beside_max_faces", 300000,
              "Models with more faces than this run the unconstrained trial after the run with regions even when "
              "unconstrained_trial_beside is true, so that two engines are never held at once (same atlas; the "
              "1M-face synthetic factory stays under 1 GB)")
          .at_least(0),
      opt_double("unconstrained_trial_share", 0.8,
                 "The unconstrained trial runs when the global ARAP distortion after merging with regions is below "
                 "this share of global_bound")
          .range(0, 1),
      opt_double("unconstrained_trial_min_singular_value", -1,
                 "min_singular_value of the unconstrained trial (its collapsed-triangle refusal); negative: the same "
                 "as min_singular_value")
          .range(-1, 1),
      opt_bool("unconstrained_trial_seam_price", false,
               "With seam_price: the unconstrained trial's first pass is priced too (false: the trial merges without "
               "the price)"),
      opt_int("unconstrained_trial_max_attempts", 0,
              "max_attempts of the unconstrained trial; 0: the same as max_attempts")
          .range(0, 1000),
      opt_double("unconstrained_trial_repaired_global_share", -1,
                 "repaired_global_share of the unconstrained trial; negative: the same as repaired_global_share")
          .range(-1, 1),
      opt_double("unconstrained_trial_second_pass_local_bound", -1,
                 "second_pass_local_bound of the unconstrained trial; negative: the same as second_pass_local_bound")
          .range(-1, 1e6),
      opt_bool("fan_targets", false,
               "Solve with target shapes whose angles close every boundary fan of the merged chart that its input UV "
               "angles would open past a full turn (the move is still measured against the input UV triangles)"),
      opt_double("fan_margin", 0.01, "Fan targets close a boundary fan at 2 pi (1 - fan_margin)").range(0, 0.5),
      opt_int("partial_weld_tries", 0,
              "A move refused as fan_overlap at a welded end of its seam is tried again with that seam vertex left "
              "unwelded (its seam edge stays cut), up to this many times; 0: never")
          .range(0, 16),
      opt_bool("fill_holes", false,
               "A move refused as fan_overlap whose local problem touches a hole of the merged chart "
               "(a boundary loop other than its outer one) is tried again with temporary triangles across its holes "
               "in the solve, so that a chart that is not a disk keeps its holes open while it deforms; the "
               "triangles never reach the atlas"),
      opt_bool("hold_full_fans", false,
               "A move refused as fan_overlap at a wedge it did not weld is tried again with the free region's "
               "boundary fans whose input UV angles add up to a turn or more (within 2%) held where earlier merges "
               "left them (their wedge and its one ring are not freed)"),
      opt_bool("cross_page", true,
               "Merge charts whose texels lie on different input pages (each face keeps its own page's texels as "
               "rest shape); false keeps every chart on one input page")
  };
}
}  // namespace

std::vector<OptionSpec> merge_option_specs(double local_bound_default) {
  std::vector<OptionSpec> specs = order_and_bound_specs(local_bound_default);
  for (auto* part : {second_pass_specs, trial_and_weld_specs}) {
    std::vector<OptionSpec> more = part();
    specs.insert(specs.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  }
  return specs;
}

MergeOptions merge_options_from(const Options& o) {
  MergeOptions m;
  m.priority = o.get_enum<Priority>("priority", {{"planarity", Priority::Planarity}, {"mmethod", Priority::MMethod}});
  m.alignment_per_edge = o.get_enum<bool>("alignment_scale", {{"seam", false}, {"edge", true}});
  m.alpha = o.get_double("alpha");
  m.global_bound = o.get_double("global_bound");
  m.local_bound = o.get_double("local_bound");
  m.min_singular_value = o.get_double("min_singular_value");
  m.repaired_local_bound = o.get_double("repaired_local_bound");
  m.repaired_global_share = o.get_double("repaired_global_share");
  m.seam_price = o.get_enum<SeamPrice>("seam_price", {{"off", SeamPrice::Off}, {"on", SeamPrice::On}, {"both", SeamPrice::Both}});
  m.max_seam_price = o.get_double("max_seam_price");
  m.seam_price_both_max_faces = static_cast<size_t>(o.get_int("seam_price_both_max_faces"));
  m.max_merges = o.get_int("max_merges");
  m.max_attempts = static_cast<int>(o.get_int("max_attempts"));
  m.max_free_vertices = static_cast<int>(o.get_int("max_free_vertices"));
  m.cross_page = o.get_bool("cross_page");
  m.close_cuts = o.get_bool("close_cuts");
  m.unconstrained_trial = o.get_bool("unconstrained_trial");
  m.unconstrained_trial_share = o.get_double("unconstrained_trial_share");
  m.unconstrained_trial_min_singular_value = o.get_double("unconstrained_trial_min_singular_value");
  m.unconstrained_trial_max_attempts = static_cast<int>(o.get_int("unconstrained_trial_max_attempts"));
  m.unconstrained_trial_seam_price = o.get_bool("unconstrained_trial_seam_price");
  m.unconstrained_trial_repaired_global_share = o.get_double("unconstrained_trial_repaired_global_share");
  m.unconstrained_trial_second_pass_local_bound = o.get_double("unconstrained_trial_second_pass_local_bound");
  m.unconstrained_trial_beside = o.get_bool("unconstrained_trial_beside");
  m.unconstrained_trial_beside_max_faces = static_cast<size_t>(o.get_int("unconstrained_trial_beside_max_faces"));
  m.fan_targets = o.get_bool("fan_targets");
  m.fan_margin = o.get_double("fan_margin");
  m.partial_weld_tries = static_cast<int>(o.get_int("partial_weld_tries"));
  m.fill_holes = o.get_bool("fill_holes");
  m.hold_full_fans = o.get_bool("hold_full_fans");
  m.second_pass = o.get_enum<SecondPass>("second_pass", {{"none", SecondPass::None}, {"across_regions", SecondPass::AcrossRegions}});
  m.second_pass_priority =
      o.get_enum<Priority>("second_pass_priority", {{"planarity", Priority::Planarity}, {"mmethod", Priority::MMethod}});
  m.second_pass_local_bound = o.get_double("second_pass_local_bound");
  m.second_pass_seam_refusal = o.get_bool("second_pass_seam_refusal");
  m.second_pass_steps = static_cast<int>(o.get_int("second_pass_steps"));
  return m;
}

json MergeReport::to_json() const {
  json j;
  // note: charts in and out, the ARAP distortion and flipped faces after merging are the framework's
  // figures of every merger (charts_in, charts_out, distortion_arap, flipped_faces): not repeated here.
  j["locked_charts"] = locked_charts;
  j["self_overlapping_charts"] = self_overlapping_charts;
  j["candidate_pairs"] = candidates_initial;
  j["merges_attempted"] = attempted;
  j["merges_accepted"] = accepted;
  j["charts_after_first_pass"] = charts_after_first_pass;
  j["merges_accepted_second_pass"] = accepted_second_pass;
  j["merges_attempted_second_pass"] = attempted_second_pass;
  j["merges_mirrored"] = accepted_mirrored;
  j["mirrored_faces_out"] = mirrored_faces_out;
  j["distortion_after_first_pass"] = distortion_after_first_pass;
  j["first_pass_budget_shares"] = first_pass_budget_shares;
  j["first_pass_lanes"] = first_pass_lanes;
  j["first_pass_seconds"] = first_pass_seconds;
  j["second_pass_seconds"] = second_pass_seconds;
  j["close_cuts_seconds"] = close_cuts_seconds;
  j["first_pass_speculated"] = first_pass_speculated;
  j["first_pass_speculation_used"] = first_pass_speculation_used;
  j["second_pass_speculated"] = second_pass_speculated;
  j["second_pass_speculation_used"] = second_pass_speculation_used;
  j["seam_figures_kept"] = seam_figures_kept;
  j["second_pass_cpu_seconds"] = second_pass_cpu_seconds;
  j["second_pass_side_cpu_seconds"] = second_pass_side_cpu_seconds;
  json rej = json::object();
  size_t total = 0;
  for (const auto& [k, v] : rejected) {
    rej[k] = v;
    total += v;
  }
  j["rejected"] = rej;
  j["rejected_total"] = total;
  j["fan_target_moves"] = fan_target_moves;
  j["repairs_tried"] = repairs_tried;
  j["repairs_untangled"] = repairs_untangled;
  j["repairs_accepted"] = repairs_accepted;
  j["partial_weld_retries"] = partial_weld_retries;
  j["partial_welds_accepted"] = partial_welds_accepted;
  j["hole_fill_retries"] = hole_fill_retries;
  j["hole_fills_accepted"] = hole_fills_accepted;
  j["holes_filled"] = holes_filled;
  j["fan_hold_retries"] = fan_hold_retries;
  j["fan_holds_accepted"] = fan_holds_accepted;
  j["cut_edges_in"] = cut_edges_in;
  j["cuts_attempted"] = cuts_attempted;
  j["cuts_closed"] = cuts_closed;
  j["cut_edges_closed"] = cut_edges_closed;
  json crej = json::object();
  for (const auto& [k, v] : cut_rejected) crej[k] = v;
  j["cut_rejected"] = crej;
  json left = json::object();
  for (const auto& [k, v] : seam_left) left[k] = {{"pairs", v.pairs}, {"edges", v.edges}, {"length_3d", v.length_3d}};
  j["seam_left"] = left;
  j["seam_left_length_3d"] = seam_left_length_3d();
  j["unconstrained_trial_run"] = unconstrained_trial_run;
  j["unconstrained_trial_kept"] = unconstrained_trial_kept;
  j["regions_seam_left_length_3d"] = regions_seam_left_length_3d;
  j["seam_price_kept"] = seam_price_kept;
  j["unpriced_seam_left_length_3d"] = unpriced_seam_left_length_3d;
  j["unconstrained_trial_beside"] = unconstrained_trial_beside;
  j["thin_faces"] = thin_faces;
  j["thin_faces_opened"] = thin_faces_opened;
  j["distortion_in"] = distortion_in;
  j["optimisation_seconds"] = optimisation_seconds;
  j["check_seconds"] = check_seconds;
  j["mean_free_vertices"] = mean_free_vertices;
  return j;
}

namespace {
/// The options the unconstrained trial runs with: the run's, with its own limits where set
/// (unconstrained_trial_*: docs/mergers.md, "The trial's own limits").
void trial_options(MergeOptions& opt) {
  if (opt.unconstrained_trial_min_singular_value >= 0)
    opt.min_singular_value = opt.unconstrained_trial_min_singular_value;
  if (opt.unconstrained_trial_max_attempts > 0) opt.max_attempts = opt.unconstrained_trial_max_attempts;
  if (!opt.unconstrained_trial_seam_price) opt.seam_price = SeamPrice::Off;
  if (opt.unconstrained_trial_repaired_global_share >= 0)
    opt.repaired_global_share = opt.unconstrained_trial_repaired_global_share;
  if (opt.unconstrained_trial_second_pass_local_bound >= 0)
    opt.second_pass_local_bound = opt.unconstrained_trial_second_pass_local_bound;
}

/// The unconstrained trial (docs/mergers.md, "Unconstrained trial"): a merge of the input atlas
/// without regions. With two threads or more it starts on a thread of its own beside the run with
/// regions (whose first pass spreads its regions over the threads, while the trial's is one queue)
/// and is dropped as soon as that run's distortion reaches the share under which the trial is used;
/// when it is needed after all, it runs again at the end. Its result does not depend on where or
/// when it ran: the engine's output is the same for any thread count.
class Trial {
 public:
  /// @param input  the atlas given to the merger (the trial beside copies it; finish() consumes it)
  /// @param charts  the input's charts (input_charts), shared with the run with regions
  Trial(const TexturedMesh& mesh, const Topology& topo, Atlas& input, const MergeOptions& opt, LocalSolver& solver,
        std::shared_future<std::vector<int>> charts)
      : mesh_(mesh), topo_(topo), input_(input), opt_(opt), solver_(solver), charts_(std::move(charts)) {}
  Trial(const Trial&) = delete;
  Trial& operator=(const Trial&) = delete;
  ~Trial() {
    drop();
    wait();
  }
  /// Starts the trial on a thread of its own.
  void start_beside() {
    started_ = true;
    thread_ = std::thread([this] { run_beside(); });
  }
  /// The trial will not be needed: a trial running beside stops at its next queue entry.
  void drop() { drop_ = true; }
  /// The run with regions has ended: a trial running beside may use the other threads now (its
  /// first pass speculates from its next queue entry on; the same atlas).
  void alone() { alone_ = true; }
  /// "off" (not started beside), "dropped" (stopped before its end) or "ended"; after finish().
  const char* beside_state() const { return !started_ ? "off" : beside_ ? "ended" : "dropped"; }
  /// Waits for the trial beside to end or stop, reporting its progress meanwhile (none when it
  /// never started). An error it met is kept for finish().
  void wait(const Progress& progress = {});
  /// The trial's report, its atlas in `atlas`: the one run beside when it ran to its end (rethrows
  /// its error), else run now on this thread.
  MergeReport finish(Atlas& atlas, const Progress& progress);

 private:
  /// @param beside  the trial runs beside the run with regions: its one queue speculates only once
  ///                that run has ended (alone()); run alone, it does from the start (the same atlas).
  MergeReport run(Atlas& atlas, const Progress& progress, const std::atomic<bool>* cancel, bool beside) const {
    const std::vector<int> no_regions;  // (the engine keeps a reference)
    MergeOptions opt = opt_;
    opt.first_pass_speculation = !beside;
    trial_options(opt);
    detail::Engine e(mesh_, topo_, atlas, no_regions, opt, solver_);
    e.input_charts_from(charts_);
    e.cancel_when(cancel);
    if (beside) e.speculate_when(&alone_);
    return e.run(progress);
  }
  void run_beside();

  const TexturedMesh& mesh_;
  const Topology& topo_;
  Atlas& input_;
  const MergeOptions& opt_;
  LocalSolver& solver_;
  std::shared_future<std::vector<int>> charts_;
  std::thread thread_;
  bool started_ = false;
  std::atomic<bool> drop_{false};
  std::atomic<bool> alone_{false};  ///< alone(): the run with regions has ended
  std::atomic<double> fraction_{0};  ///< progress of the trial beside
  std::mutex mtx_;
  std::condition_variable ended_;
  bool ended_flag_ = false;      ///< under mtx_
  std::optional<MergeReport> beside_;  ///< the trial beside's report when it ran to its end
  Atlas beside_atlas_;
  std::exception_ptr error_;
};

void Trial::run_beside() {
  try {
    beside_atlas_ = input_;
    beside_ = run(beside_atlas_, [this](double f) { fraction_ = f; }, &drop_, true);
  } catch (const detail::Engine::Cancelled&) {
    beside_atlas_ = Atlas();
  } catch (...) {
    error_ = std::current_exception();
  }
  std::lock_guard<std::mutex> lock(mtx_);
  ended_flag_ = true;
  ended_.notify_all();
}

void Trial::wait(const Progress& progress) {
  if (!thread_.joinable()) return;
  std::unique_lock<std::mutex> lock(mtx_);
  while (!ended_.wait_for(lock, std::chrono::milliseconds(100), [this] { return ended_flag_; }))
    if (progress) progress(fraction_);
  lock.unlock();
  thread_.join();
}

MergeReport Trial::finish(Atlas& atlas, const Progress& progress) {
  wait(progress);
  if (error_) std::rethrow_exception(error_);
  if (beside_) {
    atlas = std::move(beside_atlas_);
    return *beside_;
  }
  atlas = std::move(input_);
  return run(atlas, progress, nullptr, false);
}

/// The input's charts (the closing distortion summary's flip groups), the same for every engine of
/// one run_merges: built once, on a thread of its own beside the first engine's set-up (one thread
/// of it, 0.8 s on the 1M-face synthetic factory) when there are two threads, else when first needed.
std::shared_future<std::vector<int>> input_charts(const TexturedMesh& mesh, const Topology& topo) {
  return std::async(thread_count() > 1 ? std::launch::async : std::launch::deferred,
                    [&mesh, &topo] { return build_charts(mesh, topo).atlas.face_chart; })
      .share();
}

/// seam_price = both: the whole merging (with its trial) without the price, then with it; the atlas
/// that leaves less 3D seam is kept (the unpriced one on a tie).
MergeReport run_priced_or_not(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas,
                              const std::vector<int>& face_region, const MergeOptions& opt, LocalSolver& solver,
                              const Progress& progress) {
  // note: where the budget binds the price welds more seam (hard synthetic buildings: 3D seam left -16%),
  // where it does not it only puts merges off, and which of the two holds is known only after merging.
  MergeOptions o = opt;
  o.seam_price = SeamPrice::Off;
  if (mesh.num_faces() > opt.seam_price_both_max_faces)
    return run_merges(mesh, topo, atlas, face_region, o, solver, progress);
  Atlas priced = atlas;
  auto half = [&progress](double base) {
    return progress ? Progress([&progress, base](double f) { progress(base + 0.5 * f); }) : Progress();
  };
  MergeReport r = run_merges(mesh, topo, atlas, face_region, o, solver, half(0));
  o.seam_price = SeamPrice::On;
  MergeReport p = run_merges(mesh, topo, priced, face_region, o, solver, half(0.5));
  const double unpriced = r.seam_left_length_3d();
  if (p.seam_left_length_3d() < unpriced) {
    atlas = std::move(priced);
    r = std::move(p);
    r.seam_price_kept = true;
  }
  r.unpriced_seam_left_length_3d = unpriced;
  return r;
}

MergeReport run_with_regions(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas,
                             const std::vector<int>& face_region, const MergeOptions& opt, LocalSolver& solver,
                             const Progress& progress, const std::function<void()>& over_share,
                             const std::shared_future<std::vector<int>>& charts) {
  {
    detail::Engine e(mesh, topo, atlas, face_region, opt, solver);
    e.input_charts_from(charts);
    if (over_share) e.watch_distortion(opt.unconstrained_trial_share * opt.global_bound, over_share);
    MergeReport r = e.run(progress);
    if (!e.overspent()) return r;
  }
  detail::Engine e(mesh, topo, atlas, face_region, opt, solver);
  e.input_charts_from(charts);
  if (over_share) e.watch_distortion(opt.unconstrained_trial_share * opt.global_bound, over_share);
  e.use_budget_shares();
  MergeReport r = e.run(progress);
  r.first_pass_budget_shares = true;
  return r;
}
}  // namespace

MergeReport run_merges(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas, const std::vector<int>& face_region,
                       const MergeOptions& opt, LocalSolver& solver, const Progress& progress) {
  if (opt.seam_price == SeamPrice::Both) return run_priced_or_not(mesh, topo, atlas, face_region, opt, solver, progress);
  const std::shared_future<std::vector<int>> charts = input_charts(mesh, topo);
  if (!opt.unconstrained_trial || face_region.empty())
    return run_with_regions(mesh, topo, atlas, face_region, opt, solver, progress, {}, charts);
  Atlas input = atlas;
  Trial trial(mesh, topo, input, opt, solver, charts);
  const bool beside = opt.unconstrained_trial_beside && mesh.num_faces() <= opt.unconstrained_trial_beside_max_faces &&
                      thread_count() > 1 && solver.reentrant();
  if (beside) trial.start_beside();
  MergeReport r = run_with_regions(mesh, topo, atlas, face_region, opt, solver, progress,
                                   beside ? std::function<void()>([&trial] { trial.drop(); }) : nullptr, charts);
  trial.alone();
  if (!(r.distortion_out < opt.unconstrained_trial_share * opt.global_bound)) {
    trial.drop();
    trial.wait();
    r.unconstrained_trial_beside = trial.beside_state();
    return r;
  }
  // note: the regions spend a scarce budget on planar merges first; where the run leaves most of it
  // unspent they only held back merges across region borders (docs/mergers.md, "Unconstrained trial").
  Atlas trial_atlas;
  MergeReport t = trial.finish(trial_atlas, progress);
  const double with_regions = r.seam_left_length_3d();
  const bool keep = t.seam_left_length_3d() < with_regions;
  if (keep) {
    atlas = std::move(trial_atlas);
    r = std::move(t);
  }
  r.unconstrained_trial_beside = trial.beside_state();
  r.unconstrained_trial_run = true;
  r.unconstrained_trial_kept = keep;
  r.regions_seam_left_length_3d = with_regions;
  return r;
}

void run_merge_stage(StageContext& ctx, const std::string& stage, const MergeOptions& opt, LocalSolver& solver) {
  if (!ctx.mesh || !ctx.topology) throw StageError(stage + ": the context has no mesh or topology");
  const TexturedMesh& mesh = *ctx.mesh;
  if (ctx.atlas.face_chart.size() != mesh.faces.size())
    throw StageError(stage + ": the atlas has " + std::to_string(ctx.atlas.face_chart.size()) + " faces, the mesh " +
                     std::to_string(mesh.faces.size()));
  const auto& fr = ctx.regions.face_region;
  if (!fr.empty() && fr.size() != mesh.faces.size())
    throw StageError(stage + ": the detector's regions cover " + std::to_string(fr.size()) + " faces, the mesh has " +
                     std::to_string(mesh.faces.size()));
  for (size_t f = 0; f < fr.size(); ++f)
    if (fr[f] >= ctx.regions.num_regions)
      throw StageError(stage + ": face " + std::to_string(f) + " has region " + std::to_string(fr[f]) +
                       " outside [0, " + std::to_string(ctx.regions.num_regions) + ")");
  for (size_t p = 0; p < mesh.pages.size(); ++p)
    if (mesh.pages[p].width <= 0 || mesh.pages[p].height <= 0)
      throw StageError(stage + ": page " + std::to_string(p) + " has no known size");
  // note: the planarity weights are the detector's (declared once, by its options); without a
  // CPI detector the paper's defaults (PlanarityWeights) stay.
  MergeOptions o = opt;
  if (ctx.regions.planarity_weights) {
    const auto& w = *ctx.regions.planarity_weights;
    o.weights = {w[0], w[1], w[2]};
  }
  const MergeReport r =
      run_merges(mesh, *ctx.topology, ctx.atlas, fr, o, solver, [&](double f) { ctx.step(stage, f); });
  if (ctx.report) {
    json j = r.to_json();
    for (auto it = j.begin(); it != j.end(); ++it) (*ctx.report)[it.key()] = it.value();
  }
}

}  // namespace texdefrag::merge
