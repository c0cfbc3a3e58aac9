// Productions on the command line: `texdefrag run -c CONFIG FOLDER -o OUT` runs every tile of a
// production (docs/production.md). The task list for batch runners is `texdefrag tasks`
// (cli/cmd_batch.cpp), which takes the ContextCapture layout (kind, levels, copies) from
// production/production.h.
#include "commands.h"

#include "texdefrag/io/tiles3d.h"
#include "texdefrag/production/production.h"

#include <cstdio>
#include <filesystem>

namespace texdefrag::cli {

int run_production_command(const PipelineConfig& config, const std::string& input, const std::string& output_dir,
                           bool allow_missing_children, bool quiet, const ProgressFn& progress) {
  // A folder holding a tileset.json (and no metadata.xml) is that tileset (as for `texdefrag tasks`).
  const std::filesystem::path tileset = std::filesystem::path(input) / "tileset.json";
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::path(input) / "metadata.xml", ec) && is_tileset(tileset.string()))
    return run_tileset_cli(config, tileset.string(), output_dir, progress, quiet, false);
  const Production p = list_production(input, output_dir);
  ProductionRunOptions ro;
  ro.output_dir = output_dir;
  ro.progress = progress;
  ro.allow_missing_children = allow_missing_children;
  ro.on_task = [&](size_t i, const ProductionTask& t, const json& row, const json& report) {
    if (row["status"] == "failed") {  // printed even when quiet: the exit code alone does not say which
      std::fprintf(stderr, "[%zu/%zu] FAILED %s\n", i + 1, p.tasks.size(), row["error"].get<std::string>().c_str());
      return;
    }
    if (!report.is_null()) print_warnings(report, t.relative);
    if (quiet || report.is_null()) return;
    const auto& in = report["input_stats"];
    const auto& out = report["output_stats"];
    std::fprintf(stderr, "[%zu/%zu] %s: %d faces, %d charts => %d charts, %.2f MP => %.2f MP, in %.2f s\n", i + 1,
                 p.tasks.size(), t.relative.c_str(), in["faces"].get<int>(), in["charts"]["charts"].get<int>(),
                 out["charts"].get<int>(), in["megapixels"].get<double>(), out["megapixels"].get<double>(),
                 report["total_time_s"].get<double>());
  };
  const json summary = run_production(config, p, ro);
  const size_t failed = summary["failed"].get<size_t>();
  if (!quiet) {
    const json& all = summary["levels"]["all"];
    std::fprintf(stderr, "%s: %zu tiles (%s), %zu failed, %zu files copied; texture %.2f MB => %.2f MB; summary %s/texdefrag_summary.json\n",
                 input.c_str(), p.tasks.size(), p.kind.c_str(), failed, p.copies.size(),
                 all["page_bytes_in"].get<double>() / 1e6, all["page_bytes_out"].get<double>() / 1e6, output_dir.c_str());
  }
  if (failed > 0)
    std::fprintf(stderr, "texdefrag run: %zu of %zu tiles failed (listed in %s/texdefrag_summary.json)\n", failed,
                 p.tasks.size(), output_dir.c_str());
  return failed > 0 ? 1 : 0;
}

}  // namespace texdefrag::cli
