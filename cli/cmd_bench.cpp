// `texdefrag bench`: batch runs of configurations over a data set, with the M-method's (or any
// tool's) outputs beside them, results in CSV/JSON, and the figures of eval/plots (docs/bench.md).
#include "texdefrag/eval/bench.h"
#include "texdefrag/util/paths.h"

#include "commands.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>

namespace fs = std::filesystem;

namespace texdefrag::cli {
namespace {

/// Runs eval/plots/plots.py on the results folder; returns a one-line status for the user.
std::string run_plots(const std::string& results_dir) {
  const bench::PlotsResult p = bench::run_plots({"--results", results_dir}, (fs::path(results_dir) / "plots").string());
  std::cout << p.out;
  return p.figures ? "plots: figures and summary.md in " + results_dir : p.message;
}

}  // namespace

CLI::App* add_bench_command(CLI::App& app, int& exit_code) {
  struct Args {
    bench::BenchOptions o;
    bool no_plots = false;
    std::vector<std::string> eval_pair;
  };
  auto args = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "bench", "Run configurations on every model of a data set, evaluate, and tabulate (docs/bench.md)");
  bench::BenchOptions& o = args->o;
  sub->add_option("--data", o.data, "Folder of models (every file a model format reads: OBJ, glTF/GLB, OSGB; recursively) or a manifest.json");
  sub->add_option("--configs", o.configs, "Pipeline configurations: files or shipped names (labels are their file stems)");
  sub->add_option("--out", o.out_dir, "Results folder (results.jsonl, results.csv, summary.json, runs/, figures)");
  sub->add_option("-j,--jobs", o.jobs, "Pairs run at once (each in its own process)")->check(CLI::Range(1, 64));
  sub->add_option("--threads", o.threads, "Threads of each run (texdefrag run --threads; 0 = every core; default: not passed, i.e. every core)")
      ->check(CLI::Range(0, 1024));
  add_set_option(sub, o.sets, "Override an option of every configuration: STAGE.OPTION=VALUE (one per --set; repeat it for more)");
  sub->add_option("--sweep", o.sweeps, "One configuration per value: STAGE.OPTION=V1,V2,... (repeatable: all combinations)");
  sub->add_option("--external", o.externals, "Another tool's outputs evaluated as configuration NAME: NAME=DIR (repeatable)");
  sub->add_option("--samples", o.samples, "Texture fidelity samples per comparison")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1000000000)));
  sub->add_flag("--no-texture", [&o](int64_t) { o.texture = false; }, "Skip texture fidelity (faster)");
  sub->add_flag("--retry-failed", o.retry_failed, "Re-run pairs whose recorded result is a failure");
  sub->add_option("--timeout", o.timeout_s, "Seconds before a run or evaluation is killed (0 = no limit)")
      ->check(CLI::Range(0.0, 1e9));
  sub->add_flag("--no-plots", args->no_plots, "Do not run eval/plots/plots.py at the end");
  sub->add_flag("--views", o.views, "Also write chart-coloured atlas pages per model, input and output (RESULTS/views/)");
  sub->add_option("--exe", o.exe, "texdefrag executable for the child processes (default: this one)")->group("");
  sub->add_option("--eval-pair", args->eval_pair, "internal: evaluate IN OUT and print the JSON record part")
      ->expected(2)
      ->group("");
  sub->callback([args, &exit_code]() {
    bench::BenchOptions& o = args->o;
    if (!args->eval_pair.empty()) {
      try {
        std::cout << bench::evaluate_pair(args->eval_pair[0], args->eval_pair[1], o.samples, o.texture).dump() << "\n";
        std::cout.flush();
        exit_code = std::cout ? 0 : 1;
      } catch (const std::exception& e) {
        std::cerr << "texdefrag bench --eval-pair: " << e.what() << "\n";
        exit_code = 1;
      }
      return;
    }
    if (o.data.empty() || o.out_dir.empty() || (o.configs.empty() && o.externals.empty())) {
      std::cerr << "texdefrag bench: --data, --out and at least one of --configs / --external are required\n";
      exit_code = 2;
      return;
    }
    try {
      for (std::string& c : o.configs) c = resolve_config(c);
    } catch (const ConfigNotFound& e) {
      std::cerr << "texdefrag bench: " << e.what() << "\n";
      exit_code = 2;
      return;
    }
    auto mu = std::make_shared<std::mutex>();
    o.log = [mu](const std::string& line) {
      std::lock_guard<std::mutex> lock(*mu);
      std::cerr << line << "\n";
    };
    try {
      const bench::BenchSummary s = bench::run_bench(o);
      std::cerr << "bench: " << s.pairs << " pairs: " << s.ran << " ran, " << s.skipped << " skipped (already recorded), "
                << s.failed << " failed, " << s.missing << " without external output; results in " << o.out_dir
                << "/results.{jsonl,csv}, summary.json\n";
      if (!args->no_plots) std::cerr << run_plots(o.out_dir) << "\n";
      exit_code = s.failed ? 1 : 0;
    } catch (const bench::BenchError& e) {
      std::cerr << "texdefrag bench: " << e.what() << "\n";
      exit_code = 2;
    } catch (const std::exception& e) {
      std::cerr << "texdefrag bench: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

}  // namespace texdefrag::cli
