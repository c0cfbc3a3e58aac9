#include "texdefrag/stage/stage.h"

#include "texdefrag/io/output_set.h"

namespace texdefrag {

void StageContext::step(const std::string& stage, double fraction) const {
  if (progress && !progress(stage, fraction)) throw Cancelled();
}

std::string StageContext::output_path(const std::string& stage, const std::string& name) const {
  if (!outputs) throw StageError(stage + ": cannot write " + name + ": this run writes no output (no output folder)");
  try {
    return outputs->path_for(name);
  } catch (const OutputError& e) {
    throw StageError(stage + ": " + e.what());
  }
}

const char* to_string(StageKind k) {
  switch (k) {
    case StageKind::Detector: return "detectors";
    case StageKind::Merger: return "mergers";
    case StageKind::Packer: return "packers";
  }
  return "?";
}

}  // namespace texdefrag

#include <stdexcept>

namespace texdefrag {

Options make_options(const StageInfo& info, const json& values, const std::string& where,
                     std::vector<std::string>& errors) {
  json out = json::object();
  std::vector<std::string> keys;
  for (const OptionSpec& o : info.options) {
    keys.push_back(o.key);
    out[o.key] = o.default_value;
  }
  if (!values.is_object()) {
    errors.push_back(where + ": must be a JSON object, got " + values.dump());
    return Options(out);
  }
  for (auto it = values.begin(); it != values.end(); ++it) {
    if (it.key() == "type") continue;
    const OptionSpec* spec = nullptr;
    for (const OptionSpec& o : info.options)
      if (o.key == it.key()) spec = &o;
    if (!spec) {
      std::string msg = where + ": unknown option '" + it.key() + "' for " + info.name;
      const std::string near = nearest(it.key(), keys);
      if (!near.empty()) msg += " (did you mean '" + near + "'?)";
      errors.push_back(msg);
      continue;
    }
    const std::string err = check_option_value(*spec, it.value());
    if (!err.empty()) {
      errors.push_back(where + ": '" + it.key() + "' " + err);
      continue;
    }
    out[it.key()] = it.value();
  }
  for (const OptionSpec& o : info.options)
    if (o.required && (out[o.key].is_null() || (out[o.key].is_string() && out[o.key].get<std::string>().empty())))
      errors.push_back(where + ": '" + o.key + "' is required (" + o.help + ")");
  return Options(out);
}

Options default_options(const StageInfo& info, const json& overrides) {
  std::vector<std::string> errors;
  Options o = make_options(info, overrides, info.name, errors);
  if (!errors.empty()) {
    std::string msg;
    for (const auto& e : errors) msg += e + "\n";
    throw std::invalid_argument(msg);
  }
  return o;
}

}  // namespace texdefrag
