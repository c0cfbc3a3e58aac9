// `texdefrag configs [--paths]`: the shipped configurations, addressable by name with `-c NAME`
// (run, validate, bench), and the one `texdefrag run` uses without -c.
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/util/paths.h"

#include "commands.h"

#include <fstream>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

CLI::App* add_configs_command(CLI::App& app, int& exit_code) {
  auto paths = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand("configs", "List the shipped configurations (use them with -c NAME)");
  sub->add_flag("--paths", *paths, "Print each configuration's file path instead of its description");
  sub->callback([paths, &exit_code] {
    const std::vector<std::string> names = shipped_configs();
    if (names.empty()) {
      std::cerr << "texdefrag configs: no configuration found in " << config_dir() << "\n";
      exit_code = 1;
      return;
    }
    for (const std::string& n : names) {
      const std::string path = resolve_config(n);
      if (*paths) {
        std::cout << n << "\t" << path << "\n";
        continue;
      }
      std::string description;
      try {
        std::ifstream in(path);
        const json j = json::parse(in);
        if (j.is_object() && j.contains("description") && j["description"].is_string())
          description = j["description"].get<std::string>();
      } catch (const std::exception& e) {
        description = std::string("(unreadable: ") + e.what() + ")";
      }
      if (description.size() > 100) description = description.substr(0, 97) + "...";
      std::cout << (n == kDefaultConfig ? "* " : "  ") << n;
      for (size_t i = n.size(); i < 26; ++i) std::cout << ' ';
      std::cout << " " << description << "\n";
    }
    std::cout << "(* = the default of `texdefrag run`; folder: " << config_dir() << ")\n";
    exit_code = 0;
  });
  return sub;
}

}  // namespace texdefrag::cli
