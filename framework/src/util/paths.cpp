// Run-time folders relative to libtexdefrag.so, and shipped configurations by name.
#include "texdefrag/util/paths.h"

#include <dlfcn.h>

#include <algorithm>
#include <filesystem>

namespace fs = std::filesystem;

namespace texdefrag {

std::string install_root() {
  static const std::string root = [] {
    Dl_info info{};
    // Any function of this library locates it (also when loaded by Python or a plugin host).
    if (dladdr(reinterpret_cast<const void*>(&install_root), &info) == 0 || !info.dli_fname)
      throw std::runtime_error("texdefrag: cannot locate libtexdefrag (dladdr failed)");
    std::error_code ec;
    fs::path lib = fs::canonical(info.dli_fname, ec);
    if (ec) lib = fs::absolute(info.dli_fname);
    return lib.parent_path().parent_path().string();
  }();
  return root;
}

std::string plugin_dir() { return (fs::path(install_root()) / "lib" / "texdefrag" / "plugins").string(); }
std::string config_dir() { return data_dir("configs"); }
std::string data_dir(const std::string& name) { return (fs::path(install_root()) / "share" / "texdefrag" / name).string(); }

std::vector<std::string> shipped_configs() {
  std::vector<std::string> names;
  const fs::path dir = config_dir();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  for (auto it = fs::recursive_directory_iterator(dir, fs::directory_options::follow_directory_symlink, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_directory() && it->path().filename() == "bad") {
      it.disable_recursion_pending();  // configs/bad: failure cases for the tests, not configurations
      continue;
    }
    if (!it->is_regular_file() || it->path().extension() != ".json") continue;
    fs::path rel = it->path().lexically_relative(dir);
    rel.replace_extension();
    names.push_back(rel.generic_string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string resolve_config(const std::string& arg) {
  std::error_code ec;
  if (fs::is_regular_file(arg, ec)) return arg;
  std::string name = arg;
  if (name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0) name.resize(name.size() - 5);
  const std::vector<std::string> names = shipped_configs();
  if (std::find(names.begin(), names.end(), name) != names.end())
    return (fs::path(config_dir()) / (name + ".json")).string();
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  throw ConfigNotFound("configuration '" + arg + "': no such file, and not a shipped configuration (" +
                       (list.empty() ? "none found in " + config_dir() : list) + ")");
}

}  // namespace texdefrag
