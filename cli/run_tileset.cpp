// `texdefrag run` on a 3D Tiles tileset (io/tiles3d.h): every content of every level, one report
// per model plus a summary, the same layout under -o.
#include "commands.h"

#include "texdefrag/io/tiles3d.h"

#include <cstdio>
#include <iostream>

namespace texdefrag::cli {

int run_tileset_cli(const PipelineConfig& config, const std::string& tileset, const std::string& output_dir,
                    const ProgressFn& progress, bool quiet, bool print_summary,
                    const std::vector<std::string>& contents) {
  TilesetRunOptions o;
  o.tileset = tileset;
  o.output_dir = output_dir;
  o.progress = progress;
  o.contents = contents;
  const json summary = run_tileset(config, o);
  if (print_summary) {
    // One model (a batch task): its run report, as for a model file; else the tileset's summary.
    const bool one = summary.contains("reports") && summary["reports"].size() == 1;
    std::cout << (one ? summary["reports"][0] : summary).dump(2) << "\n";
  }
  for (const auto& m : summary["models"]) print_warnings(m, m["contents"][0].get<std::string>());
  if (!quiet) {
    size_t cin = 0, cout_ = 0;
    for (const auto& m : summary["models"]) {
      cin += m["charts_in"].get<size_t>();
      cout_ += m["charts_out"].get<size_t>();
    }
    std::fprintf(stderr, "%s: %zu tilesets, %zu contents in %zu models, %zu faces, %zu charts => %zu charts, page bytes %zu => %zu\n",
                 tileset.c_str(), summary["tilesets"].get<size_t>(), summary["contents"].get<size_t>(), summary["models"].size(),
                 summary["faces"].get<size_t>(), cin, cout_, summary["page_bytes_in"].get<size_t>(),
                 summary["page_bytes_out"].get<size_t>());
  }
  return 0;
}

}  // namespace texdefrag::cli
