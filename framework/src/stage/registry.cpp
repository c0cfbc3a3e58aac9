#include "texdefrag/stage/registry.h"

#include "texdefrag/util/paths.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

namespace fs = std::filesystem;

namespace texdefrag {

namespace {
/// `detectors|mergers|packers` '.' [a-z][a-z0-9_]*
bool well_formed_name(const std::string& name) {
  const size_t dot = name.find('.');
  if (dot == std::string::npos) return false;
  const std::string kind = name.substr(0, dot), rest = name.substr(dot + 1);
  if (kind != "detectors" && kind != "mergers" && kind != "packers") return false;
  if (rest.empty() || !(rest[0] >= 'a' && rest[0] <= 'z')) return false;
  for (char c : rest)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}
}  // namespace

Registry& Registry::instance() {
  static Registry r;
  return r;
}

void Registry::add(StageInfo info, const std::string& source) {
  const std::string from = source.empty() ? (current_module_.empty() ? "<built in>" : current_module_) : source;
  if (!well_formed_name(info.name))
    throw RegistryError("stage name '" + info.name + "' from " + from +
                        " is malformed (expected detectors|mergers|packers.lower_snake_case)");
  const std::string prefix = info.name.substr(0, info.name.find('.'));
  if (prefix != to_string(info.kind))
    throw RegistryError("stage '" + info.name + "' from " + from + " is declared as a " + to_string(info.kind) +
                        " stage; its name must start with '" + to_string(info.kind) + ".'");
  if (!info.create) throw RegistryError("stage '" + info.name + "' from " + from + " has no factory");
  for (const OptionSpec& o : info.options) {
    const std::string err = check_option_value(o, o.default_value);
    if (!err.empty())
      throw RegistryError("stage '" + info.name + "' from " + from + ": default of option '" + o.key + "' " + err);
  }
  auto it = stages_.find(info.name);
  if (it != stages_.end())
    throw RegistryError("stage '" + info.name + "' is registered twice: by " + it->second.source + " and by " + from);
  std::string name = info.name;
  stages_.emplace(std::move(name), Entry{std::move(info), from});
}

std::vector<std::string> Registry::plugin_dirs() {
  std::vector<std::string> dirs;
  std::error_code ec;
  if (fs::is_directory(build_plugin_dir(), ec)) dirs.emplace_back(build_plugin_dir());
  else if (fs::is_directory(install_plugin_dir(), ec)) dirs.emplace_back(install_plugin_dir());
  if (const char* env = std::getenv("TEXDEFRAG_PLUGIN_PATH")) {
    std::string s(env);
    size_t b = 0;
    while (b <= s.size()) {
      size_t e = s.find(':', b);
      if (e == std::string::npos) e = s.size();
      if (e > b) dirs.push_back(s.substr(b, e - b));
      b = e + 1;
    }
  }
  return dirs;
}

void Registry::load_module(const std::string& path) {
  void* h = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!h) {
    const char* err = dlerror();
    throw RegistryError("cannot load plugin " + path + ": " + (err ? err : "unknown error"));
  }
  using Fn = int (*)(Registry*, int);
  auto fn = reinterpret_cast<Fn>(dlsym(h, "texdefrag_plugin_register"));
  if (!fn) throw RegistryError("plugin " + path + " has no texdefrag_plugin_register entry point");
  current_module_ = path;
  try {
    if (fn(this, kPluginAbiVersion) != 0)
      throw RegistryError("plugin " + path + " was built for another plugin ABI (this texdefrag: " +
                          std::to_string(kPluginAbiVersion) + ")");
  } catch (...) {
    current_module_.clear();
    throw;
  }
  current_module_.clear();
  // note: modules stay loaded for the life of the process (stages' code lives there).
}

void Registry::load_plugins() {
  if (loaded_) return;
  loaded_ = true;
  for (const std::string& dir : plugin_dirs()) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      if (dir != build_plugin_dir() && dir != install_plugin_dir())
        throw RegistryError("TEXDEFRAG_PLUGIN_PATH names " + dir + ", which is not a folder");
      continue;
    }
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && e.path().extension() == ".so") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) load_module(f);
  }
}

const StageInfo* Registry::find(const std::string& name) const {
  auto it = stages_.find(name);
  return it == stages_.end() ? nullptr : &it->second.info;
}

std::unique_ptr<Stage> Registry::create(const std::string& name) const {
  const StageInfo* info = find(name);
  if (!info) {
    std::string msg = "unknown stage '" + name + "'";
    const std::string near = nearest(name, names());
    if (!near.empty()) msg += " (did you mean '" + near + "'?)";
    throw RegistryError(msg);
  }
  return info->create();
}

std::vector<const StageInfo*> Registry::list() const {
  std::vector<const StageInfo*> out;
  for (const auto& kv : stages_) out.push_back(&kv.second.info);
  return out;
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> out;
  for (const auto& kv : stages_) out.push_back(kv.first);
  return out;
}

const std::string& Registry::source_of(const std::string& name) const {
  static const std::string kNone;
  auto it = stages_.find(name);
  return it == stages_.end() ? kNone : it->second.source;
}

}  // namespace texdefrag
