// `texdefrag eval IN.obj OUT.obj [--json] [--samples N]`: the metrics of docs/eval.md for an input
// model and any tool's defragmented output.
#include "texdefrag/eval/metrics.h"

#include "commands.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

namespace {

/// The arguments of `texdefrag eval`, defaults from the eval option structs.
struct EvalArgs {
  std::string in, out;
  bool json = false;
  bool no_texture = false;
  size_t samples = eval::FidelityOptions{}.samples;
  double tolerance = eval::MatchOptions{}.position_tolerance;
  bool no_appearance = false;
  int mip_levels = eval::EvalOptions{}.clash_max_level;
  int render_views = eval::RenderFidelityOptions{}.views;
  int render_size = eval::RenderFidelityOptions{}.size;
  int render_steps = eval::RenderFidelityOptions{}.max_level;
  int render_supersample = eval::RenderFidelityOptions{}.supersample;
};

/// A finite number >= 0 (CLI::Range lets NaN through: every comparison with NaN is false).
CLI::Validator non_negative_number() {
  return CLI::Validator(
      [](std::string& s) {
        try {
          size_t used = 0;
          const double d = std::stod(s, &used);
          if (used == s.size() && std::isfinite(d) && d >= 0) return std::string();
        } catch (const std::exception&) {
        }
        return "must be a finite number >= 0, got '" + s + "'";
      },
      "NUMBER >= 0");
}

/// The metric options that `a` asks for (validated by the command's checks).
eval::EvalOptions eval_options(const EvalArgs& a) {
  eval::EvalOptions opt;
  opt.fidelity.samples = a.samples;
  opt.match.position_tolerance = a.tolerance;
  opt.texture = !a.no_texture;
  opt.appearance = !a.no_appearance;
  opt.clash_max_level = a.mip_levels;
  opt.render.max_level = a.render_steps;
  opt.render.supersample = a.render_supersample;
  opt.render.views = a.render_views;
  opt.render.size = a.render_size;
  return opt;
}

}  // namespace

CLI::App* add_eval_command(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* sub = app.add_subcommand("eval", "Compare an input model with a defragmented output: charts, seams, "
                                             "distortion, texture size and fidelity (docs/eval.md)");
  sub->add_option("IN", args->in, "input model: OBJ, OSGB or glTF/GLB (the model before defragmentation)")->required();
  sub->add_option("OUT", args->out, "output model, any built-in format (any tool's result for IN)")->required();
  sub->add_flag("--json", args->json, "print the JSON report instead of the text summary");
  sub->add_option("--samples", args->samples, "surface samples for texture fidelity (spread by UV area)")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1000000000)));
  sub->add_flag("--no-texture", args->no_texture, "skip texture fidelity (do not read the page images)");
  sub->add_option("--position-tolerance", args->tolerance,
                  "model units: output positions this close to an input position are the same vertex")
      ->check(non_negative_number());
  sub->add_flag("--no-appearance", args->no_appearance,
                "skip the appearance measures (texel clashes per MIP level, seam colour, rendered views)");
  sub->add_option("--mip-levels", args->mip_levels, "highest MIP level of the texel clashes and the seam colour discrepancy")
      ->check(CLI::Range(0, 16));
  sub->add_option("--render-views", args->render_views, "fixed views of the rendered-view fidelity")
      ->check(CLI::Range(1, 64));
  sub->add_option("--render-size", args->render_size,
                  "pixels per side of each rendered view at the nearest distance (halved at each step)")
      ->check(CLI::Range(16, 4096));
  sub->add_option("--render-steps", args->render_steps,
                  "distance steps of the rendered views beyond the nearest (render size / 2^step, >= 16 px)")
      ->check(CLI::Range(0, 8));
  sub->add_option("--render-supersample", args->render_supersample,
                  "samples per pixel side of the prefiltered reference at the nearest distance")
      ->check(CLI::Range(1, 16));
  sub->callback([args, &exit_code]() {
    try {
      if (args->render_size % (1 << args->render_steps) != 0 || (args->render_size >> args->render_steps) < 16)
        throw std::runtime_error("--render-size " + std::to_string(args->render_size) + " with --render-steps " +
                                 std::to_string(args->render_steps) + ": the size must be a multiple of 2^steps and "
                                 "size / 2^steps at least 16 pixels");
      for (const std::string* p : {&args->in, &args->out}) {
        std::ifstream probe(*p);
        if (!probe) throw std::runtime_error("cannot read '" + *p + "'");
      }
      const eval::EvalOptions opt = eval_options(*args);
      const eval::Comparison c = eval::compare_files(args->in, args->out, opt);
      if (args->json)
        std::cout << eval::to_json(c).dump(2) << "\n";
      else
        std::cout << eval::summary(c);
      std::cout.flush();
      exit_code = std::cout ? 0 : 1;
    } catch (const std::exception& e) {
      std::cerr << "texdefrag eval: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

}  // namespace texdefrag::cli
