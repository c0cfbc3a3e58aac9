// Where texdefrag finds its stage modules, shipped configurations and data files.
//
// Run-time folders are found relative to the texdefrag shared library itself (libtexdefrag.so,
// located with dladdr), never relative to the working directory. The build tree mirrors the
// install layout (FHS), so one rule serves both:
//   <root>/lib/libtexdefrag.so            the library (root = its folder's parent)
//   <root>/lib/texdefrag/plugins/         stage modules
//   <root>/share/texdefrag/configs/       shipped configurations (best.json, ablations/...)
//   <root>/share/texdefrag/plots/         eval/plots scripts
// with <root> = the build folder, or the install prefix (/usr for the .deb).
// Folders fixed at configure time (test data, source tree) are only for tests and development.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

// Configure-time folders (tests and development tools only).
const char* shared_data_dir();     ///< ../shared/data of the source tree (may not exist)
const char* source_dir();          ///< the repository root
const char* python_executable();   ///< Python with matplotlib, for eval/plots

/// The prefix texdefrag runs from: the parent of the folder holding libtexdefrag.so.
std::string install_root();
/// <root>/lib/texdefrag/plugins (the stage modules loaded by the registry).
std::string plugin_dir();
/// <root>/share/texdefrag/configs (the shipped configurations).
std::string config_dir();
/// <root>/share/texdefrag/<name> (other shipped data: "plots", "examples").
std::string data_dir(const std::string& name);

/// A configuration argument that is neither a readable file nor a shipped configuration's name.
struct ConfigNotFound : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Names of the shipped configurations, sorted: paths under config_dir() without ".json"
/// ("best", "paper", "ablations/arap", ...). configs/bad is not listed.
std::vector<std::string> shipped_configs();

/// Resolves `-c ARG`: an existing file is used as given; otherwise ARG (with or without ".json")
/// names a shipped configuration. Throws ConfigNotFound naming ARG and listing the shipped names.
std::string resolve_config(const std::string& name_or_path);

/// The configuration `texdefrag run` uses without -c.
constexpr const char* kDefaultConfig = "best";

}  // namespace texdefrag
