// Models, configurations and external tools' outputs of a batch (docs/bench.md).
#include "texdefrag/eval/bench.h"

#include "texdefrag/io/model_format.h"
#include "texdefrag/pipeline/pipeline.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace texdefrag::bench {
namespace {

std::string absolute_normal(const fs::path& p) {
  std::error_code ec;
  fs::path a = fs::weakly_canonical(fs::absolute(p), ec);
  if (ec) a = fs::absolute(p).lexically_normal();
  return a.string();
}

bool is_under(const std::string& path, const std::string& dir) {
  if (dir.empty()) return false;
  const std::string d = dir.back() == '/' ? dir : dir + "/";
  return path.compare(0, d.size(), d) == 0;
}

bool has_obj_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e == ".obj";
}

/// A model of a folder scan: a file a built-in model format reads (io/model_format.h: OBJ, glTF/GLB,
/// OSGB), so a production's tiles compare one by one; not JSON (a tileset.json is a whole
/// production: list it in a manifest).
bool is_model_file(const fs::path& p) {
  if (lower_extension(p.string()) == "json") return false;
  for (const ModelFormat* f : model_formats())
    if (f->can_read(p.string())) return true;
  return false;
}

/// Ids safe as folder names: every character outside [A-Za-z0-9._+=,\[\]-] becomes '_'.
std::string safe_name(const std::string& s) {
  std::string r = s;
  for (char& c : r) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (!(std::isalnum(u) || c == '.' || c == '_' || c == '-' || c == '+' || c == '=' || c == ',' || c == '[' ||
          c == ']'))
      c = '_';
  }
  if (r.empty() || r == "." || r == "..") r = "_" + r;
  return r;
}

std::vector<BenchModel> from_manifest(const fs::path& manifest) {
  std::ifstream in(manifest);
  if (!in) throw BenchError("cannot read manifest " + manifest.string());
  json j;
  try {
    in >> j;
  } catch (const json::exception& e) {
    throw BenchError("manifest " + manifest.string() + ": not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("models") || !j["models"].is_array())
    throw BenchError("manifest " + manifest.string() + ": expected an object with a \"models\" array");
  const fs::path base = manifest.parent_path();
  std::vector<BenchModel> models;
  std::set<std::string> ids;
  size_t index = 0;
  for (const json& m : j["models"]) {
    const std::string where = manifest.string() + ": models[" + std::to_string(index++) + "]";
    if (!m.is_object()) throw BenchError(where + ": expected an object");
    std::string rel;
    for (const char* key : {"path", "obj"})
      if (m.contains(key)) {
        if (!m[key].is_string()) throw BenchError(where + "." + key + ": expected a string");
        rel = m[key].get<std::string>();
        break;
      }
    if (rel.empty()) throw BenchError(where + ": no \"path\" (or \"obj\")");
    fs::path p = rel;
    if (p.is_relative()) p = base / p;
    if (!fs::is_regular_file(p)) throw BenchError(where + ": model file " + p.string() + " does not exist");
    BenchModel bm;
    bm.path = absolute_normal(p);
    for (const char* key : {"id", "name"})
      if (m.contains(key) && m[key].is_string()) {
        bm.id = m[key].get<std::string>();
        break;
      }
    if (bm.id.empty()) bm.id = p.stem().string();
    bm.id = safe_name(bm.id);
    if (!ids.insert(bm.id).second) throw BenchError(where + ": duplicate model id '" + bm.id + "'");
    for (const auto& [k, v] : m.items())
      if (k != "path" && k != "obj" && k != "id" && k != "name" && (v.is_primitive() && !v.is_null())) bm.meta[k] = v;
    models.push_back(std::move(bm));
  }
  return models;
}

std::vector<BenchModel> from_folder(const fs::path& root, const std::string& exclude_dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  const std::string excl = exclude_dir.empty() ? std::string() : absolute_normal(exclude_dir);
  for (fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end;
       it != end; it.increment(ec)) {
    if (ec) throw BenchError("cannot list " + root.string() + ": " + ec.message());
    const fs::path p = it->path();
    if (it->is_directory() && !excl.empty() && absolute_normal(p) == excl) {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file() || !is_model_file(p)) continue;
    if (is_under(absolute_normal(p), excl)) continue;
    // Outputs of texdefrag carry their run report beside them.
    if (fs::exists(p.parent_path() / (p.stem().string() + ".report.json"))) continue;
    files.push_back(p);
  }
  if (ec) throw BenchError("cannot list " + root.string() + ": " + ec.message());
  std::map<std::string, int> stem_count;
  for (const auto& f : files) ++stem_count[f.stem().string()];
  std::vector<BenchModel> models;
  for (const auto& f : files) {
    BenchModel m;
    m.path = absolute_normal(f);
    if (stem_count[f.stem().string()] == 1) {
      m.id = safe_name(f.stem().string());
    } else {
      std::string rel = f.lexically_relative(root).replace_extension().generic_string();
      std::replace(rel.begin(), rel.end(), '/', '_');
      m.id = safe_name(rel);
    }
    models.push_back(std::move(m));
  }
  return models;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  return parts;
}

/// "STAGE.OPTION=VALUE" -> (STAGE.OPTION, VALUE); throws BenchError naming `what`.
std::pair<std::string, std::string> split_assignment(const std::string& s, const std::string& what) {
  const size_t eq = s.find('=');
  if (eq == std::string::npos || eq == 0) throw BenchError(what + " '" + s + "': expected STAGE.OPTION=VALUE");
  const std::string key = s.substr(0, eq);
  if (key.find('.') == std::string::npos || key.front() == '.' || key.back() == '.')
    throw BenchError(what + " '" + s + "': the key must be STAGE.OPTION (e.g. packer.gutter)");
  return {key, s.substr(eq + 1)};
}

std::string option_part(const std::string& key) { return key.substr(key.rfind('.') + 1); }

/// True when `name` is `stem` followed by nothing or a non-alphanumeric character.
bool stem_prefix(const std::string& name, const std::string& stem) {
  if (name.compare(0, stem.size(), stem) != 0) return false;
  return name.size() == stem.size() || !std::isalnum(static_cast<unsigned char>(name[stem.size()]));
}

std::vector<fs::path> sorted_objs(const fs::path& dir) {
  std::vector<fs::path> r;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return r;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && has_obj_extension(e.path())) r.push_back(e.path());
  std::sort(r.begin(), r.end());
  return r;
}

}  // namespace

std::vector<BenchModel> discover_models(const std::string& data, const std::string& exclude_dir) {
  const fs::path p = data;
  std::error_code ec;
  std::vector<BenchModel> models;
  if (fs::is_directory(p, ec)) {
    models = from_folder(p, exclude_dir);
  } else if (fs::is_regular_file(p, ec)) {
    if (p.extension() != ".json") throw BenchError("--data " + data + ": expected a folder or a manifest .json file");
    models = from_manifest(p);
  } else {
    throw BenchError("--data " + data + ": no such folder or file");
  }
  if (models.empty()) throw BenchError("--data " + data + ": no model (*.obj) found");
  std::sort(models.begin(), models.end(), [](const BenchModel& a, const BenchModel& b) { return a.id < b.id; });
  return models;
}

namespace {

/// One --sweep KEY=V1,V2,...: the option and its values (none empty).
struct Sweep {
  std::string key;
  std::vector<std::string> values;
};

/// The --sweep arguments; BenchError for an empty value in a list.
std::vector<Sweep> parse_sweeps(const std::vector<std::string>& sweeps) {
  std::vector<Sweep> sw;
  for (const std::string& s : sweeps) {
    const auto [key, list] = split_assignment(s, "--sweep");
    Sweep w{key, split(list, ',')};
    for (const auto& v : w.values)
      if (v.empty()) throw BenchError("--sweep '" + s + "': empty value in the list");
    sw.push_back(std::move(w));
  }
  return sw;
}

/// Every combination of the swept values (an index per sweep), in order: the last sweep varies
/// fastest; one empty combination without sweeps.
std::vector<std::vector<size_t>> sweep_combinations(const std::vector<Sweep>& sw) {
  std::vector<std::vector<size_t>> combos(1);
  for (const Sweep& w : sw) {
    std::vector<std::vector<size_t>> next;
    for (const auto& c : combos)
      for (size_t i = 0; i < w.values.size(); ++i) {
        auto n = c;
        n.push_back(i);
        next.push_back(std::move(n));
      }
    combos = std::move(next);
  }
  return combos;
}

/// The configuration file `path` (label stem `stem`) with the --set overrides `sets` (labelled
/// set_labels) and the swept values `combo` of `sw`; labelled stem[set,...,sweep,...].
BenchConfig swept_config(const std::string& path, const std::string& stem, const std::vector<std::string>& sets,
                         const std::vector<std::string>& set_labels, const std::vector<Sweep>& sw,
                         const std::vector<size_t>& combo) {
  BenchConfig c;
  c.base = stem;
  c.path = absolute_normal(path);
  c.overrides = sets;
  std::vector<std::string> parts = set_labels;
  std::vector<std::string> keys, values;
  for (size_t k = 0; k < sw.size(); ++k) {
    const std::string& v = sw[k].values[combo[k]];
    c.overrides.push_back(sw[k].key + "=" + v);
    parts.push_back(option_part(sw[k].key) + "=" + v);
    keys.push_back(sw[k].key);
    values.push_back(v);
  }
  for (size_t k = 0; k < keys.size(); ++k) {
    c.sweep_key += (k ? "," : "") + keys[k];
    c.sweep_value += (k ? "," : "") + values[k];
  }
  c.label = stem;
  if (!parts.empty()) {
    c.label += "[";
    for (size_t k = 0; k < parts.size(); ++k) c.label += (k ? "," : "") + parts[k];
    c.label += "]";
  }
  c.label = safe_name(c.label);
  return c;
}

}  // namespace

std::vector<BenchConfig> expand_configs(const std::vector<std::string>& config_paths,
                                        const std::vector<std::string>& sets,
                                        const std::vector<std::string>& sweeps,
                                        const std::vector<std::string>& externals) {
  std::vector<std::string> set_labels;
  for (const std::string& s : sets) {
    const auto [key, value] = split_assignment(s, "--set");
    set_labels.push_back(option_part(key) + "=" + value);
  }
  // Every combination of the swept values, in order.
  const std::vector<Sweep> sw = parse_sweeps(sweeps);
  const std::vector<std::vector<size_t>> combos = sweep_combinations(sw);

  std::vector<BenchConfig> out;
  std::set<std::string> labels;
  auto add = [&](BenchConfig c) {
    if (!labels.insert(c.label).second)
      throw BenchError("two configurations are labelled '" + c.label + "' (configuration files need distinct names)");
    out.push_back(std::move(c));
  };
  for (const std::string& path : config_paths) {
    if (!fs::is_regular_file(path)) throw BenchError("--configs: no such file " + path);
    const std::string stem = safe_name(fs::path(path).stem().string());
    for (const auto& combo : combos) add(swept_config(path, stem, sets, set_labels, sw, combo));
  }
  for (const std::string& e : externals) {
    const size_t eq = e.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == e.size())
      throw BenchError("--external '" + e + "': expected NAME=DIR");
    BenchConfig c;
    c.label = c.base = safe_name(e.substr(0, eq));
    const std::string dir = e.substr(eq + 1);
    if (!fs::is_directory(dir)) throw BenchError("--external '" + e + "': no such folder " + dir);
    c.external_dir = absolute_normal(dir);
    add(std::move(c));
  }
  if (out.empty()) throw BenchError("nothing to run: give --configs and/or --external");
  return out;
}

void validate_configs(const std::vector<BenchConfig>& configs) {
  std::string errors;
  for (const BenchConfig& c : configs) {
    if (c.external()) continue;
    try {
      load_config(c.path, c.overrides);
    } catch (const ConfigError& e) {
      errors += "configuration " + c.label + " (" + c.path + "):\n" + e.what() + "\n";
    } catch (const std::exception& e) {
      errors += "configuration " + c.label + " (" + c.path + "): " + e.what() + "\n";
    }
  }
  if (!errors.empty()) throw BenchError(errors);
}

std::string find_external_output(const std::string& dir, const std::string& model_stem) {
  const fs::path d = dir;
  const fs::path own = d / model_stem;
  const std::string defrag = model_stem + "_defrag.obj";
  std::error_code ec;
  if (fs::is_regular_file(own / defrag, ec)) return absolute_normal(own / defrag);
  const auto in_own = sorted_objs(own);
  for (const auto& p : in_own)
    if (stem_prefix(p.filename().string(), model_stem)) return absolute_normal(p);
  if (fs::is_regular_file(d / defrag, ec)) return absolute_normal(d / defrag);
  for (const auto& p : sorted_objs(d))
    if (stem_prefix(p.filename().string(), model_stem)) return absolute_normal(p);
  std::vector<fs::path> subdirs;
  for (const auto& e : fs::directory_iterator(d, ec))
    if (e.is_directory()) subdirs.push_back(e.path());
  std::sort(subdirs.begin(), subdirs.end());
  for (const auto& s : subdirs)
    if (fs::is_regular_file(s / defrag, ec)) return absolute_normal(s / defrag);
  if (in_own.size() == 1) return absolute_normal(in_own[0]);
  return "";
}

json parse_tool_log(const std::string& log_path) {
  std::ifstream in(log_path);
  if (!in) return json::object();
  json j = json::object();
  static const std::regex key_number(R"(^\s*([A-Za-z][A-Za-z0-9]*)\s+([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*$)");
  static const std::regex processing(R"(Processing took\s+([-+0-9.eE]+)\s+seconds)");
  static const std::regex packed(R"(Packed\s+([0-9]+)\s+charts in\s+([-+0-9.eE]+)\s+seconds)");
  static const std::regex total(R"(^\s*TOTAL\s+[-+0-9.eE]+\s*,\s*([-+0-9.eE]+)\s+secs)");
  static const std::regex energy(R"(Atlas energy (before|after) optimization is\s+([-+0-9.eE]+))");
  static const std::regex removed_dup(R"(Removed\s+([0-9]+)\s+duplicate vertices)");
  static const std::regex removed_nm(R"(Removed\s+([0-9]+)\s+non-manifold faces)");
  std::string line;
  std::smatch m;
  auto number = [](const std::string& s) -> json {
    try {
      size_t used = 0;
      const double d = std::stod(s, &used);
      return used == s.size() ? json(d) : json(nullptr);
    } catch (const std::exception&) {
      return json(nullptr);
    }
  };
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (std::regex_match(line, m, key_number) && m[1] != "TOTAL") {
      j[m[1].str()] = number(m[2].str());
    } else if (std::regex_search(line, m, processing)) {
      j["processing_time_s"] = number(m[1].str());
    } else if (std::regex_search(line, m, packed)) {
      j["packed_charts"] = number(m[1].str());
      j["packing_time_s"] = number(m[2].str());
    } else if (std::regex_search(line, m, total)) {
      j["optimization_time_s"] = number(m[1].str());  // the last TOTAL wins
    } else if (std::regex_search(line, m, energy)) {
      j[std::string("energy_") + m[1].str()] = number(m[2].str());
    } else if (std::regex_search(line, m, removed_dup)) {
      j["removed_duplicate_vertices"] = number(m[1].str());
    } else if (std::regex_search(line, m, removed_nm)) {
      j["removed_non_manifold_faces"] = number(m[1].str());
    }
  }
  return j;
}

}  // namespace texdefrag::bench
