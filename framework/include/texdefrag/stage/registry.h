// Stage registry and plugin loading.
//
// Every stage, built-in or not, is a shared module exporting
//   extern "C" int texdefrag_plugin_register(texdefrag::Registry* r, int abi_version);
// (use TEXDEFRAG_PLUGIN below). Modules are loaded from lib/texdefrag/plugins beside libtexdefrag.so (util/paths.h) and
// from each folder of TEXDEFRAG_PLUGIN_PATH (':'-separated). A name registered twice is an error
// naming both module files; a module that fails to load is an error naming the file and dlerror().
#pragma once

#include "texdefrag/stage/stage.h"

#include <map>
#include <string>
#include <vector>

namespace texdefrag {

/// Raised whenever a class a stage module derives from or calls (stage/stage.h, stage/registry.h)
/// or a data structure it receives (core/mesh.h's TexturedMesh, ...) changes its layout or virtual
/// functions, so a module built against older headers is refused with an error naming it instead
/// of crashing. 2: Merger::distortion_budget (2026-12-02). 3: TexturedMesh::colors (2026-12-02).
constexpr int kPluginAbiVersion = 3;

struct RegistryError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Registry {
 public:
  /// The process-wide registry.
  static Registry& instance();

  /// Adds a stage. Throws RegistryError when the name is malformed (`kind.name`, lower case, digits
  /// and '_'), its prefix does not match info.kind, or the name is already registered.
  void add(StageInfo info, const std::string& source);

  /// Loads every module in the default folder and in TEXDEFRAG_PLUGIN_PATH, once. A `.so` that is
  /// not a texdefrag module (no `texdefrag_plugin_register` in its dynamic symbols, checked before it
  /// is loaded) is skipped with a warning on stderr naming it (listed by skipped()). Throws on the
  /// first broken texdefrag module or duplicate name.
  void load_plugins();
  /// Loads one module file (it must be a texdefrag module).
  void load_module(const std::string& path);
  /// Files load_plugins() skipped, with the reason ("FILE: not a texdefrag plugin (...)").
  const std::vector<std::string>& skipped() const { return skipped_; }

  const StageInfo* find(const std::string& name) const;
  /// Creates a stage by name; throws RegistryError with the nearest name suggested.
  std::unique_ptr<Stage> create(const std::string& name) const;
  std::vector<const StageInfo*> list() const;
  std::vector<std::string> names() const;
  const std::string& source_of(const std::string& name) const;

  /// Folders searched by load_plugins(), in order.
  static std::vector<std::string> plugin_dirs();

 private:
  struct Entry { StageInfo info; std::string source; };
  std::map<std::string, Entry> stages_;
  bool loaded_ = false;
  std::string current_module_;
  std::vector<std::string> skipped_;
};

}  // namespace texdefrag

/// Defines the module entry point registering the listed stage classes. Each class needs a static
/// `static texdefrag::StageInfo info();`.
#define TEXDEFRAG_PLUGIN(...)                                                                \
  extern "C" __attribute__((visibility("default"))) int texdefrag_plugin_register(           \
      texdefrag::Registry* r, int abi) {                                                     \
    if (abi != texdefrag::kPluginAbiVersion) return 1;                                       \
    texdefrag::detail::register_all<__VA_ARGS__>(*r);                                        \
    return 0;                                                                                \
  }

namespace texdefrag::detail {
template <class... S>
void register_all(Registry& r) {
  (r.add(S::info(), ""), ...);
}
}  // namespace texdefrag::detail
