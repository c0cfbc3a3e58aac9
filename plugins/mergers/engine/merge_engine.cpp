// Seam merging with exact rollback: Liu et al. 2024, "Planar feature-preserving texture
// defragmentation method for 3D urban building models" (Remote Sensing 16(22) 4154), section 2.2
// (merge order, rigid alignment, weld, local optimisation within alpha * displacement, whole-seam
// acceptance), and Maggiordomo, Cignoni, Tarini 2021, "Texture defragmentation for
// photo-reconstructed 3D models" (the M-method's cost, refusals and acceptance tests).
#include "merge_engine.h"

#include "engine_internal.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <cmath>
#include <numeric>
#include <queue>
#include <unordered_map>

namespace texdefrag::merge {

std::vector<OptionSpec> merge_option_specs(double local_bound_default) {
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
      opt_int("max_merges", 100000000, "Stop after this many accepted merges").at_least(0),
      opt_int("max_attempts", 3,
              "Attempts per chart pair; a rejected pair is retried only after one of its charts changed")
          .range(1, 1000),
      opt_int("max_free_vertices", 2000, "Largest free region of one merge (nearest wedges to the seam first)")
          .range(1, 10000000),
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
               "hold"),
      opt_bool("unconstrained_trial", false,
               "With regions: when the run ends below unconstrained_trial_share x global_bound (the regions had no "
               "scarce budget to allocate), merge again from the input without regions and keep that atlas when it "
               "leaves a shorter 3D seam"),
      opt_double("unconstrained_trial_share", 0.8,
                 "The unconstrained trial runs when the global ARAP distortion after merging with regions is below "
                 "this share of global_bound")
          .range(0, 1),
      opt_bool("fan_targets", false,
               "Solve with target shapes whose angles close every boundary fan of the merged chart that its input UV "
               "angles would open past a full turn (the move is still measured against the input UV triangles)"),
      opt_double("fan_margin", 0.01, "Fan targets close a boundary fan at 2 pi (1 - fan_margin)").range(0, 0.5),
      opt_bool("cross_page", true,
               "Merge charts whose texels lie on different input pages (each face keeps its own page's texels as "
               "rest shape); false keeps every chart on one input page"),
  };
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
  m.max_merges = o.get_int("max_merges");
  m.max_attempts = static_cast<int>(o.get_int("max_attempts"));
  m.max_free_vertices = static_cast<int>(o.get_int("max_free_vertices"));
  m.cross_page = o.get_bool("cross_page");
  m.close_cuts = o.get_bool("close_cuts");
  m.unconstrained_trial = o.get_bool("unconstrained_trial");
  m.unconstrained_trial_share = o.get_double("unconstrained_trial_share");
  m.fan_targets = o.get_bool("fan_targets");
  m.fan_margin = o.get_double("fan_margin");
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
  j["merges_mirrored"] = accepted_mirrored;
  j["mirrored_faces_out"] = mirrored_faces_out;
  j["distortion_after_first_pass"] = distortion_after_first_pass;
  j["first_pass_budget_shares"] = first_pass_budget_shares;
  j["first_pass_lanes"] = first_pass_lanes;
  j["first_pass_seconds"] = first_pass_seconds;
  j["second_pass_seconds"] = second_pass_seconds;
  j["close_cuts_seconds"] = close_cuts_seconds;
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
  j["thin_faces"] = thin_faces;
  j["thin_faces_opened"] = thin_faces_opened;
  j["distortion_in"] = distortion_in;
  j["optimisation_seconds"] = optimisation_seconds;
  j["check_seconds"] = check_seconds;
  j["mean_free_vertices"] = mean_free_vertices;
  return j;
}

namespace {
MergeReport run_with_regions(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas,
                             const std::vector<int>& face_region, const MergeOptions& opt, LocalSolver& solver,
                             const Progress& progress) {
  {
    detail::Engine e(mesh, topo, atlas, face_region, opt, solver);
    MergeReport r = e.run(progress);
    if (!e.overspent()) return r;
  }
  detail::Engine e(mesh, topo, atlas, face_region, opt, solver);
  e.use_budget_shares();
  MergeReport r = e.run(progress);
  r.first_pass_budget_shares = true;
  return r;
}
}  // namespace

MergeReport run_merges(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas, const std::vector<int>& face_region,
                       const MergeOptions& opt, LocalSolver& solver, const Progress& progress) {
  const bool trial = opt.unconstrained_trial && !face_region.empty();
  Atlas input;
  if (trial) input = atlas;
  MergeReport r = run_with_regions(mesh, topo, atlas, face_region, opt, solver, progress);
  if (!trial || !(r.distortion_out < opt.unconstrained_trial_share * opt.global_bound)) return r;
  // note: the regions spend a scarce budget on planar merges first; where the run leaves most of it
  // unspent they only held back merges across region borders (docs/mergers.md, "Unconstrained trial").
  const std::vector<int> no_regions;  // (the engine keeps a reference)
  detail::Engine e(mesh, topo, input, no_regions, opt, solver);
  MergeReport t = e.run(progress);
  const double with_regions = r.seam_left_length_3d();
  const bool keep = t.seam_left_length_3d() < with_regions;
  if (keep) {
    atlas = std::move(input);
    r = std::move(t);
  }
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
