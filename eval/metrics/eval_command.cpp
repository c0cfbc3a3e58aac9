// `texdefrag eval IN.obj OUT.obj [--json] [--samples N]`: the metrics of docs/eval.md for an input
// model and any tool's defragmented output.
#include "texdefrag/eval/metrics.h"

#include "commands.h"  // cli/commands.h

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

CLI::App* add_eval_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string in, out;
    bool json = false;
    bool no_texture = false;
    size_t samples = eval::FidelityOptions{}.samples;
    double tolerance = eval::MatchOptions{}.position_tolerance;
  };
  auto args = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("eval", "Compare an input model with a defragmented output: charts, seams, "
                                             "distortion, texture size and fidelity (docs/eval.md)");
  sub->add_option("IN", args->in, "input OBJ (the model before defragmentation)")->required();
  sub->add_option("OUT", args->out, "output OBJ (any tool's result for IN)")->required();
  sub->add_flag("--json", args->json, "print the JSON report instead of the text summary");
  sub->add_option("--samples", args->samples, "surface samples for texture fidelity (spread by UV area)")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1000000000)));
  sub->add_flag("--no-texture", args->no_texture, "skip texture fidelity (do not read the page images)");
  sub->add_option("--position-tolerance", args->tolerance,
                  "model units: output positions this close to an input position are the same vertex")
      ->check(CLI::Validator(
          [](std::string& s) {
            // note: CLI::Range lets NaN through (every comparison with NaN is false).
            try {
              size_t used = 0;
              const double d = std::stod(s, &used);
              if (used == s.size() && std::isfinite(d) && d >= 0) return std::string();
            } catch (const std::exception&) {
            }
            return "must be a finite number >= 0, got '" + s + "'";
          },
          "NUMBER >= 0"));
  sub->callback([args, &exit_code]() {
    try {
      for (const std::string* p : {&args->in, &args->out}) {
        std::ifstream probe(*p);
        if (!probe) throw std::runtime_error("cannot read '" + *p + "'");
      }
      eval::EvalOptions opt;
      opt.fidelity.samples = args->samples;
      opt.match.position_tolerance = args->tolerance;
      opt.texture = !args->no_texture;
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
