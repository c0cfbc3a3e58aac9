#include "subcommand_check.h"

#include "texdefrag/stage/options.h"

#include <iostream>
#include <string>
#include <vector>

namespace texdefrag::cli {

int check_subcommand_name(CLI::App& app, int argc, char** argv) {
  if (argc < 2 || argv[1][0] == '-') return 0;
  const std::string word = argv[1];
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) names.push_back(sub->get_name());
  for (const std::string& n : names)
    if (n == word) return 0;
  std::string valid;
  for (const std::string& n : names) valid += (valid.empty() ? "" : ", ") + n;
  std::cerr << "texdefrag: unknown subcommand '" << word << "' (valid: " << valid << ")";
  const std::string near = nearest(word, names);
  if (!near.empty()) std::cerr << "; did you mean '" << near << "'?";
  std::cerr << "\n";
  return 2;
}

}  // namespace texdefrag::cli
