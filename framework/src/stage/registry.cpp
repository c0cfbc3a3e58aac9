#include "texdefrag/stage/registry.h"

#include "texdefrag/util/paths.h"

#include <dlfcn.h>
#include <elf.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

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

constexpr const char* kEntry = "texdefrag_plugin_register";

/// A file mapped read-only (empty when it cannot be opened or mapped).
struct MappedFile {
  const char* data = nullptr;
  size_t size = 0;

  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat st {};
    if (::fstat(fd, &st) == 0 && st.st_size > 0) {
      void* p = ::mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) {
        data = static_cast<const char*>(p);
        size = static_cast<size_t>(st.st_size);
      }
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data) ::munmap(const_cast<char*>(data), size);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
};

/// Whether the ELF64 shared object at `path` defines the global function `kEntry` in its dynamic
/// symbol table, read from the file (the library is not loaded: a stray library's constructors
/// never run). `why` says what was found when not.
/// note: the file is mapped, not read: only the headers and the dynamic symbols are touched (reading
/// the 11 shipped plugins whole, 6.7 MB through a stream, was most of `validate`'s 0.1 s).
bool defines_entry(const std::string& path, std::string& why) {
  const MappedFile file(path);
  const char* const data = file.data;
  const size_t size = file.size;
  if (!data || size < sizeof(Elf64_Ehdr) || std::memcmp(data, ELFMAG, SELFMAG) != 0 || data[EI_CLASS] != ELFCLASS64) {
    why = "not a 64-bit ELF shared object";
    return false;
  }
  Elf64_Ehdr eh;
  std::memcpy(&eh, data, sizeof eh);
  const auto section = [&](size_t i, Elf64_Shdr& sh) {
    const size_t off = static_cast<size_t>(eh.e_shoff) + i * sizeof(Elf64_Shdr);
    if (off + sizeof sh > size) return false;
    std::memcpy(&sh, data + off, sizeof sh);
    return sh.sh_offset <= size && sh.sh_size <= size - sh.sh_offset;
  };
  for (size_t i = 0; i < eh.e_shnum; ++i) {
    Elf64_Shdr sym, str;
    if (!section(i, sym) || sym.sh_type != SHT_DYNSYM || !section(sym.sh_link, str)) continue;
    for (size_t k = 0; k < sym.sh_size / sizeof(Elf64_Sym); ++k) {
      Elf64_Sym e;
      std::memcpy(&e, data + sym.sh_offset + k * sizeof e, sizeof e);
      if (e.st_shndx == SHN_UNDEF || ELF64_ST_TYPE(e.st_info) != STT_FUNC || e.st_name >= str.sh_size) continue;
      const char* name = data + str.sh_offset + e.st_name;
      if (std::strncmp(name, kEntry, static_cast<size_t>(str.sh_size - e.st_name)) == 0) return true;
    }
  }
  why = std::string("no ") + kEntry + " entry point";
  return false;
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
  if (fs::is_directory(plugin_dir(), ec)) dirs.emplace_back(plugin_dir());  // relative to libtexdefrag.so
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
      if (dir != plugin_dir())
        throw RegistryError("TEXDEFRAG_PLUGIN_PATH names " + dir + ", which is not a folder");
      continue;
    }
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && e.path().extension() == ".so") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      std::string why;
      if (!defines_entry(f, why)) {
        skipped_.push_back(f + ": not a texdefrag plugin (" + why + ")");
        std::cerr << "texdefrag: warning: skipping " << skipped_.back() << "\n";
        continue;
      }
      load_module(f);
    }
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
