// Sub-commands contributed by eval/ (eval, bench, synth) and cli/cmd_*.cpp to the texdefrag command line.
// Each adds itself to `app` and returns the sub-command; the callback sets `exit_code`
// (0 ok, 1 failure, 2 usage or configuration error).
#pragma once

#include "texdefrag/pipeline/pipeline.h"

#include <CLI/CLI.hpp>

namespace texdefrag::cli {
CLI::App* add_eval_command(CLI::App& app, int& exit_code);   // eval/metrics
CLI::App* add_bench_command(CLI::App& app, int& exit_code);  // eval/bench
CLI::App* add_synth_command(CLI::App& app, int& exit_code);  // eval/synth
CLI::App* add_buildings_command(CLI::App& app, int& exit_code);  // eval/buildings
// cli/cmd_batch.cpp (docs/batch.md)
CLI::App* add_tasks_command(CLI::App& app, int& exit_code);  // the task list of a production
CLI::App* add_batch_command(CLI::App& app, int& exit_code);  // execs tools/batch/texdefrag_batch
CLI::App* add_report_command(CLI::App& app, int& exit_code); // cli/cmd_report.cpp, eval/report
/// `run` on a 3D Tiles tileset JSON (cli/run_tileset.cpp). Returns the exit code.
int run_tileset_cli(const PipelineConfig& config, const std::string& tileset, const std::string& output_dir,
                    const ProgressFn& progress, bool quiet, bool print_summary);
}  // namespace texdefrag::cli

#include "texdefrag/pipeline/pipeline.h"

namespace texdefrag::cli {
/// `texdefrag run` on a production folder (cli/cmd_production.cpp). Returns the exit code.
int run_production_command(const PipelineConfig& config, const std::string& input, const std::string& output_dir,
                           bool allow_missing_children, bool quiet, const ProgressFn& progress);
}  // namespace texdefrag::cli
