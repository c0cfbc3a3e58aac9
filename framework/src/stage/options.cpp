#include "texdefrag/stage/options.h"

#include "texdefrag/io/output_set.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace texdefrag {

const char* to_string(OptionType t) {
  switch (t) {
    case OptionType::Bool: return "bool";
    case OptionType::Int: return "int";
    case OptionType::Double: return "number";
    case OptionType::String: return "string";
    case OptionType::Enum: return "enum";
    case OptionType::InputPath: return "input path";
    case OptionType::OutputPath: return "output name";
    case OptionType::StageRef: return "stage";
  }
  return "?";
}

namespace {
OptionBuilder make(std::string key, OptionType t, json def, std::string help) {
  OptionBuilder b;
  b.spec.key = std::move(key);
  b.spec.type = t;
  b.spec.default_value = std::move(def);
  b.spec.help = std::move(help);
  return b;
}

const char* json_type_name(const json& v) {
  if (v.is_boolean()) return "bool";
  if (v.is_number_integer()) return "integer";
  if (v.is_number()) return "number";
  if (v.is_string()) return "string";
  if (v.is_array()) return "array";
  if (v.is_object()) return "object";
  return "null";
}

std::string fmt_num(double d) {
  std::ostringstream s;
  s << d;
  return s.str();
}
}  // namespace

OptionBuilder opt_bool(std::string key, bool def, std::string help) {
  return make(std::move(key), OptionType::Bool, def, std::move(help));
}
OptionBuilder opt_int(std::string key, long long def, std::string help) {
  return make(std::move(key), OptionType::Int, def, std::move(help));
}
OptionBuilder opt_double(std::string key, double def, std::string help) {
  return make(std::move(key), OptionType::Double, def, std::move(help));
}
OptionBuilder opt_string(std::string key, std::string def, std::string help) {
  return make(std::move(key), OptionType::String, std::move(def), std::move(help));
}
OptionBuilder opt_enum(std::string key, std::string def, std::vector<std::string> choices, std::string help) {
  OptionBuilder b = make(std::move(key), OptionType::Enum, std::move(def), std::move(help));
  b.spec.choices = std::move(choices);
  return b;
}

OptionBuilder opt_input_path(std::string key, std::string help) {
  return make(std::move(key), OptionType::InputPath, "", std::move(help));
}
OptionBuilder opt_output_path(std::string key, std::string help) {
  return make(std::move(key), OptionType::OutputPath, "", std::move(help));
}
OptionBuilder opt_stage(std::string key, std::string kind, std::string help) {
  OptionBuilder b = make(std::move(key), OptionType::StageRef, "", std::move(help));
  b.spec.stage_kind = std::move(kind);
  return b;
}

namespace {
/// A StageRef value: a registered stage of the declared kind.
std::string check_stage_ref(const OptionSpec& spec, const std::string& name) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  const StageInfo* info = reg.find(name);
  std::vector<std::string> candidates;
  for (const StageInfo* i : reg.list())
    if (spec.stage_kind.empty() || spec.stage_kind == to_string(i->kind)) candidates.push_back(i->name);
  if (info && (spec.stage_kind.empty() || spec.stage_kind == to_string(info->kind))) return {};
  std::string msg = "= \"" + name + "\" is not a registered " + (spec.stage_kind.empty() ? std::string("stage") : spec.stage_kind + " stage");
  const std::string near = nearest(name, candidates);
  if (!near.empty()) msg += " (did you mean \"" + near + "\"?)";
  return msg;
}
}  // namespace

std::string check_option_value(const OptionSpec& spec, const json& v) {
  switch (spec.type) {
    case OptionType::InputPath:
    case OptionType::OutputPath:
    case OptionType::StageRef: {
      if (!v.is_string()) return std::string("must be a string, got ") + json_type_name(v);
      const std::string s = v.get<std::string>();
      if (s.empty()) return {};  // none (an error only when required: make_options)
      if (spec.type == OptionType::InputPath) {
        std::error_code ec;
        if (!std::filesystem::is_regular_file(s, ec)) return "= \"" + s + "\": no such file";
        return {};
      }
      if (spec.type == OptionType::OutputPath) {
        const std::string problem = relative_name_problem(s);
        if (!problem.empty())
          return "= \"" + s + "\" " + problem + " (outputs are file names inside the output folder, never paths elsewhere)";
        return {};
      }
      return check_stage_ref(spec, s);
    }
    case OptionType::Bool:
      if (!v.is_boolean()) return std::string("must be a bool, got ") + json_type_name(v);
      return {};
    case OptionType::Int: {
      if (!v.is_number_integer()) {
        if (v.is_number_float()) return "must be an integer, got " + v.dump();
        return std::string("must be an integer, got ") + json_type_name(v);
      }
      const double d = static_cast<double>(v.get<long long>());
      if ((spec.min && d < *spec.min) || (spec.max && d > *spec.max))
        return "= " + v.dump() + " outside [" + (spec.min ? fmt_num(*spec.min) : "-inf") + ", " +
               (spec.max ? fmt_num(*spec.max) : "inf") + "]";
      return {};
    }
    case OptionType::Double: {
      if (!v.is_number()) return std::string("must be a number, got ") + json_type_name(v);
      const double d = v.get<double>();
      if (!std::isfinite(d)) return "must be finite";
      if ((spec.min && d < *spec.min) || (spec.max && d > *spec.max))
        return "= " + v.dump() + " outside [" + (spec.min ? fmt_num(*spec.min) : "-inf") + ", " +
               (spec.max ? fmt_num(*spec.max) : "inf") + "]";
      return {};
    }
    case OptionType::String:
      if (!v.is_string()) return std::string("must be a string, got ") + json_type_name(v);
      return {};
    case OptionType::Enum: {
      if (!v.is_string()) return std::string("must be a string, got ") + json_type_name(v);
      const std::string s = v.get<std::string>();
      if (std::find(spec.choices.begin(), spec.choices.end(), s) != spec.choices.end()) return {};
      std::string msg = "= \"" + s + "\" is not one of";
      for (const auto& c : spec.choices) msg += " \"" + c + "\"";
      const std::string near = nearest(s, spec.choices);
      if (!near.empty()) msg += " (did you mean \"" + near + "\"?)";
      return msg;
    }
  }
  return "unknown option type";
}

const json& Options::at(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) throw std::logic_error("option '" + key + "' was not declared");
  return *it;
}
bool Options::get_bool(const std::string& key) const { return at(key).get<bool>(); }
long long Options::get_int(const std::string& key) const { return at(key).get<long long>(); }
double Options::get_double(const std::string& key) const { return at(key).get<double>(); }
std::string Options::get_string(const std::string& key) const { return at(key).get<std::string>(); }

size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_d = std::max<size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    const size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

}  // namespace texdefrag
