// Option declarations: declared once per stage, they drive JSON validation, `plugins --describe`,
// the docs' option tables and typed access. Values are never clamped or coerced: a wrong type or an
// out-of-range value is a configuration error naming the key.
#pragma once

#include <nlohmann/json.hpp>

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace texdefrag {

using json = nlohmann::json;

/// InputPath: a file the stage reads (must exist when the configuration is validated; the run never
/// writes onto it). OutputPath: a name of a file the stage writes, relative to the run's output
/// folder (a plain relative name, io/output_set.h; written through StageContext::output_path).
/// StageRef: the qualified name of a registered stage (of `stage_kind` when set).
enum class OptionType { Bool, Int, Double, String, Enum, InputPath, OutputPath, StageRef };

const char* to_string(OptionType t);

struct OptionSpec {
  std::string key;
  OptionType type = OptionType::Double;
  json default_value;                 ///< must itself validate
  std::optional<double> min, max;     ///< inclusive range for Int and Double
  std::vector<std::string> choices;   ///< for Enum
  std::string unit;                   ///< e.g. "deg", "texels"; empty when unitless
  std::string help;                   ///< one sentence
  /// A value must be given: a configuration without it (or with "" for a string kind) is an error
  /// naming the key when validated.
  bool required = false;
  std::string stage_kind;             ///< for StageRef: "detectors", "mergers" or "packers"; empty = any
};

/// Fluent helpers for declaring options: opt_double("angle_deg", 25, "...").range(0, 90).unit("deg")
struct OptionBuilder {
  OptionSpec spec;
  OptionBuilder& range(double lo, double hi) { spec.min = lo; spec.max = hi; return *this; }
  OptionBuilder& at_least(double lo) { spec.min = lo; return *this; }
  OptionBuilder& unit(std::string u) { spec.unit = std::move(u); return *this; }
  OptionBuilder& required() { spec.required = true; return *this; }
  operator OptionSpec() const { return spec; }  // NOLINT(google-explicit-constructor)
};
OptionBuilder opt_bool(std::string key, bool def, std::string help);
OptionBuilder opt_int(std::string key, long long def, std::string help);
OptionBuilder opt_double(std::string key, double def, std::string help);
OptionBuilder opt_string(std::string key, std::string def, std::string help);
OptionBuilder opt_enum(std::string key, std::string def, std::vector<std::string> choices, std::string help);
/// A file the stage reads; default "" (none). Add .required() when the stage cannot run without it.
OptionBuilder opt_input_path(std::string key, std::string help);
/// A file name the stage writes in the output folder; default "" (none).
OptionBuilder opt_output_path(std::string key, std::string help);
/// Another stage by qualified name, of kind `kind` ("detectors"...; empty = any); default "" (none).
OptionBuilder opt_stage(std::string key, std::string kind, std::string help);

/// Validated option values of one stage: every declared key present (defaults filled in).
class Options {
 public:
  Options() = default;
  explicit Options(json values) : values_(std::move(values)) {}
  bool get_bool(const std::string& key) const;
  long long get_int(const std::string& key) const;
  double get_double(const std::string& key) const;
  std::string get_string(const std::string& key) const;
  /// The value of an Enum option as `E`, through its table of (choice, value) pairs. A value not in
  /// the table throws std::invalid_argument naming the key (never a silent default).
  template <class E>
  E get_enum(const std::string& key, std::initializer_list<std::pair<const char*, E>> table) const {
    const std::string v = get_string(key);
    for (const auto& [name, e] : table)
      if (v == name) return e;
    throw std::invalid_argument("option '" + key + "' = \"" + v + "\" is not one of its declared choices");
  }
  const json& values() const { return values_; }

 private:
  const json& at(const std::string& key) const;
  json values_ = json::object();
};

/// Validates `value` against `spec`. Returns an empty string when valid, else the message body
/// (without the key prefix), e.g. "= 95 outside [0, 90]" or "must be a number, got string".
std::string check_option_value(const OptionSpec& spec, const json& value);

/// Damerau-free Levenshtein distance; used for "did you mean" suggestions.
size_t edit_distance(const std::string& a, const std::string& b);
/// The candidate nearest to `word` within a small distance, or empty.
std::string nearest(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace texdefrag
