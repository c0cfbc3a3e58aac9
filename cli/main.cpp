// texdefrag command line: run a pipeline, list and describe stages, evaluate, benchmark, synthesise.
// Exit codes: 0 ok, 1 failure (bad input data, stage error), 2 usage or configuration error.
#include "commands.h"
#include "subcommand_check.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/io/tiles3d.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/production/production.h"
#include "texdefrag/stage/describe.h"
#include "texdefrag/util/parallel.h"
#include "texdefrag/util/paths.h"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>

using namespace texdefrag;

namespace {

/// A one-line progress bar on a terminal; silent otherwise.
ProgressFn make_progress(bool quiet) {
  if (quiet || !isatty(STDERR_FILENO)) return nullptr;
  return [](const std::string& stage, double f) {
    const int width = 30;
    const int filled = static_cast<int>(f * width + 0.5);
    std::fprintf(stderr, "\r%-26s [%s%s] %3d%%", stage.c_str(), std::string(static_cast<size_t>(filled), '#').c_str(),
                 std::string(static_cast<size_t>(width - filled), ' ').c_str(), static_cast<int>(f * 100 + 0.5));
    if (f >= 1.0) std::fprintf(stderr, "\r%-70s\r", "");
    std::fflush(stderr);
    return true;
  };
}

std::string option_range(const OptionSpec& o) {
  if (o.type == OptionType::Enum) {
    std::string s;
    for (const auto& c : o.choices) s += (s.empty() ? "" : "|") + c;
    return s;
  }
  if (!o.min && !o.max) return "";
  auto num = [](double d) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", d);
    return std::string(buf);
  };
  return "[" + (o.min ? num(*o.min) : std::string("-inf")) + ", " + (o.max ? num(*o.max) : std::string("inf")) + "]";
}

json describe_json(const StageInfo& info, const std::string& source) { return describe_stage(info, source); }

void print_describe(const StageInfo& info, const std::string& source) {
  std::cout << info.name << ": " << info.description << "\n";
  std::cout << "  doc: " << info.doc << "\n  module: " << source << "\n";
  if (info.options.empty()) {
    std::cout << "  (no options)\n";
    return;
  }
  std::cout << "  options:\n";
  for (const OptionSpec& o : info.options) {
    std::cout << "    " << o.key << " (" << to_string(o.type);
    const std::string r = option_range(o);
    if (!r.empty()) std::cout << " " << r;
    if (!o.unit.empty()) std::cout << ", " << o.unit;
    std::cout << ", default " << o.default_value.dump() << ")\n      " << o.help << "\n";
  }
}

/// Runs a sub-command body and maps what it throws to the exit code contract: configuration and
/// plugin errors 2, anything else (bad input data, stage errors, cancellation) 1.
template <class F>
int guarded(F&& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    std::cerr << "configuration error:\n" << e.what() << "\n";
    return 2;
  } catch (const ConfigNotFound& e) {
    std::cerr << "configuration error:\n" << e.what() << "\n";
    return 2;
  } catch (const RegistryError& e) {
    std::cerr << "plugin error: " << e.what() << "\n";
    return 2;
  } catch (const Cancelled&) {
    std::cerr << "cancelled\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}

/// The summary line of `run` on one model (stderr): faces, charts in => out, megapixels, time.
/// `report` is that run's report (pipeline.h); `input` names the model.
void print_run_summary(const std::string& input, const json& report) {
  const auto& in = report["input_stats"];
  const auto& out = report["output_stats"];
  const double cin = in["charts"]["charts"].get<double>(), cout_ = out["charts"].get<double>();
  std::fprintf(stderr, "%s: %d faces, %d charts => %d charts (%.1f%%), %.2f MP => %.2f MP, in %.2f s\n",
               input.c_str(), in["faces"].get<int>(), static_cast<int>(cin), static_cast<int>(cout_),
               cin > 0 ? 100.0 * (cout_ - cin) / cin : 0.0, in["megapixels"].get<double>(),
               out["megapixels"].get<double>(), report["total_time_s"].get<double>());
}

/// Adds `texdefrag run` (one model, a production folder or a tileset) to `app`; its callback sets
/// `exit_code` (0 ok, 1 failure, 2 usage or configuration error). `app` keeps the parsed arguments.
void add_run_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string config_path, input, output_dir;
    std::vector<std::string> sets;
    bool quiet = false, no_write = false, print_report = false;
    int threads = 0;
    bool allow_missing = false;
    std::vector<std::string> contents;
  };
  auto a = std::make_shared<Args>();
  auto* run = app.add_subcommand("run", "Run a pipeline configuration on one model");
  run->add_option("--config,-c", a->config_path,
                  "Configuration: a JSON file or a shipped name (`texdefrag configs`); default: best");
  run->add_option("input", a->input, "Input model (OBJ, OSGB, glTF/GLB), production folder (docs/production.md) or 3D Tiles tileset JSON")->required();
  run->add_option("-o,--output", a->output_dir, "Output folder (created; must not be the input's folder)");
  cli::add_set_option(run, a->sets, "Override an option: SECTION.OPTION=VALUE or STAGE.OPTION=VALUE (one per --set; repeat it for more)");
  run->add_flag("--quiet,-q", a->quiet, "No progress bar and no summary line");
  run->add_flag("--no-write", a->no_write, "Run the stages and report, write nothing");
  run->add_flag("--report", a->print_report, "Print the run report JSON on standard output");
  run->add_option("--threads", a->threads, "Threads inside the run (0 = every core; the output does not depend on it)")
      ->check(CLI::Range(0, 1024));
  run->add_flag("--allow-missing-children", a->allow_missing,
                "Process models whose referenced child files (OSGB PagedLOD levels) are missing; listed in the report");
  run->add_option("--contents", a->contents,
                  "Tileset input: only the model holding these contents (relative names; texdefrag batch's tasks)");
  run->callback([a, &exit_code] {
    exit_code = guarded([&] {
      set_thread_count(a->threads);
      const PipelineConfig cfg =
          load_config(resolve_config(a->config_path.empty() ? kDefaultConfig : a->config_path), a->sets);
      if (a->output_dir.empty() && !a->no_write) {
        std::cerr << "texdefrag run: -o OUTDIR is required (or --no-write)\n";
        return 2;
      }
      if (is_production(a->input))
        return cli::run_production_command(cfg, a->input, a->output_dir, a->allow_missing, a->quiet,
                                           make_progress(a->quiet));
      if (is_tileset(a->input))
        return cli::run_tileset_cli(cfg, a->input, a->output_dir, make_progress(a->quiet), a->quiet, a->print_report,
                                    a->contents);
      if (!a->contents.empty())
        throw std::runtime_error("--contents applies to a tileset JSON input, not to " + a->input);
      RunOptions ro;
      ro.input = a->input;
      ro.output_dir = a->output_dir;
      ro.write_output = !a->no_write;
      ro.allow_missing_children = a->allow_missing;
      ro.progress = make_progress(a->quiet);
      const json report = run_pipeline(cfg, ro);
      if (a->print_report) std::cout << report.dump(2) << "\n";
      cli::print_warnings(report, "");
      if (!a->quiet) print_run_summary(a->input, report);
      return 0;
    });
  });
}

/// Adds `texdefrag validate` (a configuration checked without reading any mesh) to `app`; its
/// callback sets `exit_code` as guarded() maps it.
void add_validate_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string config_path;
    std::vector<std::string> sets;
  };
  auto a = std::make_shared<Args>();
  auto* validate = app.add_subcommand("validate", "Validate a pipeline configuration without reading any mesh");
  validate->add_option("--config,-c", a->config_path, "Configuration: a JSON file or a shipped name")->required();
  cli::add_set_option(validate, a->sets, "Override an option (as in run)");
  validate->callback([a, &exit_code] {
    exit_code = guarded([&] {
      load_config(resolve_config(a->config_path), a->sets);
      std::cout << a->config_path << ": ok\n";
      return 0;
    });
  });
}

/// `texdefrag plugins`: lists every stage (name and description, or JSON), or describes the one
/// named `describe`. Returns the exit code: 0, or 2 for an unknown stage (nearest name suggested).
int list_or_describe_stages(const std::string& describe, bool as_json) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  std::vector<std::pair<const StageInfo*, std::string>> all;
  for (const StageInfo* i : reg.list()) all.emplace_back(i, reg.source_of(i->name));
  all.emplace_back(&texture_stage_info(), "framework");
  all.emplace_back(&writer_stage_info(), "framework");
  if (!describe.empty()) {
    for (const auto& [info, src] : all)
      if (info->name == describe) {
        if (as_json) std::cout << describe_json(*info, src).dump(2) << "\n";
        else print_describe(*info, src);
        return 0;
      }
    std::vector<std::string> names;
    for (const auto& p : all) names.push_back(p.first->name);
    std::cerr << "unknown stage '" << describe << "'";
    const std::string near = nearest(describe, names);
    if (!near.empty()) std::cerr << " (did you mean '" << near << "'?)";
    std::cerr << "\n";
    return 2;
  }
  if (as_json) {
    json arr = json::array();
    for (const auto& [info, src] : all) arr.push_back(describe_json(*info, src));
    std::cout << arr.dump(2) << "\n";
  } else {
    for (const auto& [info, src] : all) std::printf("%-28s %s\n", info->name.c_str(), info->description.c_str());
  }
  return 0;
}

/// Adds `texdefrag plugins [--describe NAME] [--json]` to `app`; its callback sets `exit_code`.
void add_plugins_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string describe;
    bool as_json = false;
  };
  auto a = std::make_shared<Args>();
  auto* plugins = app.add_subcommand("plugins", "List stages, or describe one's options");
  plugins->add_option("--describe", a->describe, "Stage to describe (e.g. packers.shelf)");
  plugins->add_flag("--json", a->as_json, "JSON output");
  plugins->callback([a, &exit_code] {
    exit_code = guarded([&] { return list_or_describe_stages(a->describe, a->as_json); });
  });
}

}  // namespace

int main(int argc, char** argv) {
  cli::use_huge_pages(argv);
  CLI::App app{"texdefrag: texture defragmentation of photogrammetric building models"};
  app.require_subcommand(1);
  app.set_version_flag("--version,-V", cli::version_text());
  int exit_code = 0;

  add_run_command(app, exit_code);
  add_validate_command(app, exit_code);
  add_plugins_command(app, exit_code);
  cli::add_eval_command(app, exit_code);
  cli::add_bench_command(app, exit_code);
  cli::add_synth_command(app, exit_code);
  cli::add_buildings_command(app, exit_code);
#ifdef TEXDEFRAG_HAVE_REPORT
  cli::add_report_command(app, exit_code);
#endif
  cli::add_configs_command(app, exit_code);

  cli::add_tasks_command(app, exit_code);
  cli::add_batch_command(app, exit_code);

  if (const int code = cli::check_subcommand_name(app, argc, argv)) return code;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  return exit_code;
}
