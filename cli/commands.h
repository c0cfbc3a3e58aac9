// Sub-commands of the texdefrag command line, one file each (cli/cmd_<name>.cpp). Each adds itself
// to `app` and returns the sub-command; its callback sets `exit_code` (0 ok, 1 failure, 2 usage or
// configuration error). The libraries they drive (eval/, framework) know nothing of the CLI.
#pragma once

#include "texdefrag/pipeline/pipeline.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>
#include <vector>

namespace texdefrag::cli {
/// Adds `--set KEY=VALUE` to `sub`: exactly one value per occurrence (repeat `--set` for more), so
/// an argument after it (`run --set a.b=1 in.obj -o out`) is never taken as another value.
inline CLI::Option* add_set_option(CLI::App* sub, std::vector<std::string>& sets, const std::string& help) {
  return sub->add_option("--set", sets, help)->allow_extra_args(false);
}
/// Prints a run report's "warnings" (pipeline.h) to stderr, one line each, after `prefix` (a
/// model's name in a production or tileset; "" for one model). Printed even with --quiet.
inline void print_warnings(const nlohmann::json& report, const std::string& prefix) {
  if (!report.contains("warnings")) return;
  for (const auto& w : report["warnings"])
    std::fprintf(stderr, "warning: %s%s\n", prefix.empty() ? "" : (prefix + ": ").c_str(), w.get<std::string>().c_str());
}
CLI::App* add_eval_command(CLI::App& app, int& exit_code);     // cmd_eval.cpp (eval/metrics)
CLI::App* add_bench_command(CLI::App& app, int& exit_code);    // cmd_bench.cpp (eval/bench)
CLI::App* add_synth_command(CLI::App& app, int& exit_code);    // cmd_synth.cpp (eval/synth)
CLI::App* add_buildings_command(CLI::App& app, int& exit_code);  // cmd_buildings.cpp (eval/buildings)
CLI::App* add_tasks_command(CLI::App& app, int& exit_code);  // cmd_batch.cpp: the task list of a production
CLI::App* add_batch_command(CLI::App& app, int& exit_code);  // cmd_batch.cpp: execs tools/batch/texdefrag_batch
CLI::App* add_report_command(CLI::App& app, int& exit_code); // cmd_report.cpp (eval/report)
/// `run` on a 3D Tiles tileset JSON (cli/run_tileset.cpp). Returns the exit code.
/// contents: empty for the whole tileset, else one model's contents (TilesetRunOptions::contents);
/// then print_summary prints that model's run report (as `run --report` on a model file).
int run_tileset_cli(const PipelineConfig& config, const std::string& tileset, const std::string& output_dir,
                    const ProgressFn& progress, bool quiet, bool print_summary,
                    const std::vector<std::string>& contents = {});
CLI::App* add_configs_command(CLI::App& app, int& exit_code);  // cmd_configs.cpp

/// For `run` and `bench`, restarts the program once with glibc's malloc asking for transparent huge
/// pages (cli/huge_pages.cpp; TEXDEFRAG_HUGE_PAGES=0 turns it off). Called first in main(); returns
/// when no restart is needed.
void use_huge_pages(char** argv);

/// `texdefrag --version`: version, source revision, compiler, formats and optional features
/// (cmd_version.cpp, from the build's generated build_info.cpp).
std::string version_text();
}  // namespace texdefrag::cli

#include "texdefrag/pipeline/pipeline.h"

namespace texdefrag::cli {
/// `texdefrag run` on a production folder (cli/cmd_production.cpp). Returns the exit code.
int run_production_command(const PipelineConfig& config, const std::string& input, const std::string& output_dir,
                           bool allow_missing_children, bool quiet, const ProgressFn& progress);
}  // namespace texdefrag::cli
