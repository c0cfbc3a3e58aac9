// `texdefrag buildings`: cut a tile into one model per building plus a remainder (docs/paper.md).
//   texdefrag buildings TILE.obj -o OUT [--min-faces 200] [--set OPTION=VALUE ...]
#include "texdefrag/buildings/extract.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"

#include "commands.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

CLI::App* add_buildings_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string input, out;
    int min_faces = buildings::ExtractOptions{}.min_faces;
    std::vector<std::string> sets;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("buildings", "Cut a tile into one OBJ per building (detectors.semantic) plus a "
                                                  "remainder; every face in exactly one output, checked (docs/paper.md)");
  sub->add_option("input", a->input, "Input OBJ")->required();
  sub->add_option("-o,--output", a->out, "Output folder (created; not the input's folder)")->required();
  sub->add_option("--min-faces", a->min_faces, "Smaller building components go to the remainder")->check(CLI::Range(1, 100000000));
  add_set_option(sub, a->sets, "Option of detectors.semantic: OPTION=VALUE (VALUE is JSON or a bare string; one per --set)");
  sub->callback([a, &exit_code] {
    try {
      buildings::ExtractOptions o;
      o.min_faces = a->min_faces;
      for (const std::string& s : a->sets) {
        const size_t eq = s.find('=');
        if (eq == std::string::npos || eq == 0) {
          std::cerr << "texdefrag buildings: --set '" << s << "': expected OPTION=VALUE\n";
          exit_code = 2;
          return;
        }
        const std::string v = s.substr(eq + 1);
        o.detector[s.substr(0, eq)] = json::accept(v) ? json::parse(v) : json(v);
      }
      const TexturedMesh mesh = read_obj(a->input);
      const buildings::Extraction ex = buildings::extract_buildings(mesh, o);
      const json m = buildings::write_parts(mesh, a->input, ex, a->out);
      for (const auto& p : m["parts"]) std::printf("%-14s %8zu faces  %s\n", p["name"].get<std::string>().c_str(),
                                                     p["faces"].get<size_t>(), p["obj"].get<std::string>().c_str());
      exit_code = 0;
    } catch (const ConfigError& e) {
      std::cerr << "configuration error:\n" << e.what() << "\n";
      exit_code = 2;
    } catch (const std::exception& e) {
      std::cerr << "error: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

}  // namespace texdefrag::cli
