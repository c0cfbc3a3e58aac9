#include "texdefrag/pipeline/pipeline.h"

#include "texdefrag/io/output_set.h"

#include <fstream>
#include <sstream>

namespace texdefrag {
namespace {

std::string join_lines(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? "\n" : "") + v[i];
  return s;
}

StageInfo framework_info(std::string name, std::string description, std::string doc, std::vector<OptionSpec> options) {
  StageInfo i;
  i.name = std::move(name);
  i.description = std::move(description);
  i.doc = std::move(doc);
  i.options = std::move(options);
  return i;
}

struct Section {
  const char* key;
  StageKind kind;
  const char* default_type;
};
const Section kSections[] = {
    {"detector", StageKind::Detector, "detectors.none"},
    {"merger", StageKind::Merger, "mergers.none"},
    {"packer", StageKind::Packer, "packers.shelf"},
};

/// Parses VALUE of an override: JSON when it parses, else a bare string.
json parse_value(const std::string& v) {
  try {
    return json::parse(v);
  } catch (const json::exception&) {  // a syntax error, or a number that overflows (out_of_range 406)
    return json(v);
  }
}

}  // namespace

ConfigError::ConfigError(std::vector<std::string> errs)
    : std::runtime_error(join_lines(errs)), errors(std::move(errs)) {}

const StageInfo& texture_stage_info() {
  static const StageInfo info = framework_info(
      "texture.resample", "Renders the output atlas pages from the input pages", "docs/texture.md",
      {opt_enum("filter", "bilinear", {"nearest", "bilinear", "bicubic"}, "Sampling filter of the input pages"),
       opt_enum("fit", "least_squares", {"sample", "least_squares"},
                "Texels of resampled faces: the input at their centre, or least-squares fitted so the page read bilinearly matches the input read bilinearly"),
       opt_int("fit_iterations", 4, "Conjugate-gradient iterations of fit 'least_squares'").range(1, 200),
       opt_enum("fill", "pull_push", {"none", "dilate", "pull_push"}, "How texels around charts are filled for MIP-mapping"),
       opt_int("dilate_width", 8, "Width of the dilation when fill is 'dilate'").range(0, 256).unit("texels"),
       opt_bool("fill_blocks", true,
                "After fill pull_push, 8x8 blocks no chart touches take their mean and partly covered blocks a smooth continuation of their texels (smaller JPEG pages)")});
  return info;
}

const StageInfo& writer_stage_info() {
  static const StageInfo info = framework_info(
      "writers.obj", "Writes the output model (the input's format) and its atlas pages", "docs/io.md",
      {opt_enum("image_format", "input", {"input", "png", "jpeg"},
                "Format of the output pages; 'input': JPEG when every textured input page is JPEG, else PNG"),
       opt_int("jpeg_quality", 95, "JPEG quality of JPEG pages when no input quality is matched").range(1, 100),
       opt_bool("match_input_quality", true,
                "JPEG pages take the quality estimated from the input JPEG pages' quantisation tables"),
       opt_enum("jpeg_quality_fit", "input_bytes", {"input_bytes", "none"},
                "JPEG pages at the input's estimated quality: 'input_bytes' raises it to the highest quality (up to "
                "jpeg_max_quality) whose page bytes stay at or below the input's page bytes; 'none' keeps the estimate"),
       opt_int("jpeg_max_quality", 100, "Highest quality jpeg_quality_fit may raise JPEG pages to").range(1, 100),
       opt_enum("jpeg_subsampling", "4:4:4", {"4:4:4", "4:2:2", "4:2:0", "input"},
                "Chroma subsampling of JPEG pages; 'input': the finest of the input JPEG pages' (4:4:4 when unknown)"),
       opt_enum("jpeg_tables", "flat", {"flat", "standard"},
                "Quantisation tables of JPEG pages: 'flat' (one step for every coefficient: the most fidelity per "
                "byte in PSNR) or 'standard' (libjpeg's Annex K tables); qualities keep libjpeg's scale (docs/io.md)"),
       opt_bool("jpeg_progressive", true, "JPEG pages as progressive scans with optimised Huffman tables (smaller, same pixels)"),
       opt_string("name", "", "Output file stem; empty keeps the input's stem"),
       opt_bool("write_report", true, "Write <stem>.report.json beside the output"),
       opt_enum("draco", "none", {"none", "lossless", "quantized"},
                "glTF output: Draco-compress rewritten primitives; 'lossless' keeps positions bit-identical, "
                "'quantized' is exact only for Draco-quantised inputs (docs/io.md)"),
       opt_int("draco_position_bits", 16, "glTF output.draco=quantized: position bits for inputs not Draco-quantised").range(8, 30),
       opt_int("draco_texcoord_bits", 16, "glTF output.draco=quantized: texture coordinate bits").range(8, 30),
       opt_int("draco_generic_bits", 16, "glTF output.draco=quantized: bits of other float attributes").range(8, 30)});
  return info;
}

namespace {

/// True for an override "SECTION.type=X" (the first '.' is the one before "type=").
bool is_type_override(const std::string& o) {
  return o.find(".type=") != std::string::npos && o.find('.') == o.find(".type=");
}

/// The overrides with every "SECTION.type=X" first, each group in its given order.
std::vector<std::string> order_overrides(const std::vector<std::string>& overrides) {
  std::vector<std::string> ordered;
  for (const std::string& o : overrides)
    if (is_type_override(o)) ordered.push_back(o);
  for (const std::string& o : overrides)
    if (!is_type_override(o)) ordered.push_back(o);
  return ordered;
}

/// The section an override's target names: a section key, or the type of a section in cfg (the
/// default type where cfg names none); empty if neither.
std::string section_of_target(const json& cfg, const std::string& target) {
  std::string section;
  for (const Section& s : kSections)
    if (target == s.key) section = s.key;
  if (target == "texture" || target == "output") section = target;
  if (!section.empty()) return section;
  for (const Section& s : kSections) {
    const std::string type = cfg.contains(s.key) && cfg[s.key].is_object() && cfg[s.key].contains("type") &&
                                     cfg[s.key]["type"].is_string()
                                 ? cfg[s.key]["type"].get<std::string>()
                                 : s.default_type;
    if (type == target) section = s.key;
  }
  if (target == texture_stage_info().name) section = "texture";
  if (target == writer_stage_info().name) section = "output";
  return section;
}

/// Applies one override o ("section.option=value" or "kind.stage.option=value") to cfg; a
/// "SECTION.type=X" of a stage section resets it to {"type": X}. Problems go to errors.
void apply_override(json& cfg, const std::string& o, const std::string& origin, std::vector<std::string>& errors) {
  const size_t eq = o.find('=');
  const size_t dot = o.rfind('.', eq);
  if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq) {
    errors.push_back("--set " + o + ": expected STAGE.OPTION=VALUE (e.g. packer.gutter=4)");
    return;
  }
  const std::string target = o.substr(0, dot);
  const std::string key = o.substr(dot + 1, eq - dot - 1);
  const json value = parse_value(o.substr(eq + 1));
  const std::string section = section_of_target(cfg, target);
  if (section.empty()) {
    errors.push_back("--set " + o + ": '" + target + "' is neither a section (detector, merger, packer, texture, output) "
                     "nor the type of one in " + origin);
    return;
  }
  if (!cfg.contains(section)) cfg[section] = json::object();
  if (!cfg[section].is_object()) {
    errors.push_back("--set " + o + ": section '" + section + "' of " + origin + " is not an object");
    return;
  }
  if (key == "type" && section != "texture" && section != "output") {
    cfg[section] = json{{"type", value}};
    return;
  }
  cfg[section][key] = value;
}

/// Reports unknown top-level keys of cfg (with did-you-mean) and a non-string description.
void check_top_level_keys(const json& cfg, const std::string& origin, std::vector<std::string>& errors) {
  std::vector<std::string> known = {"description", "texture", "output"};
  for (const Section& s : kSections) known.push_back(s.key);
  for (auto it = cfg.begin(); it != cfg.end(); ++it) {
    if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
    std::string msg = origin + ": unknown key '" + it.key() + "'";
    const std::string near = nearest(it.key(), known);
    if (!near.empty()) msg += " (did you mean '" + near + "'?)";
    errors.push_back(msg);
  }
  if (cfg.contains("description") && !cfg["description"].is_string())
    errors.push_back(origin + ": 'description' must be a string");
}

/// The registered stage of kind s.kind named type, or nullptr after adding the error (unknown
/// stage with did-you-mean among that kind, or a stage of another kind).
const StageInfo* find_section_stage(Registry& reg, const Section& s, const std::string& type,
                                    std::vector<std::string>& errors) {
  const StageInfo* info = reg.find(type);
  if (!info) {
    std::vector<std::string> same_kind;
    for (const StageInfo* si : reg.list())
      if (si->kind == s.kind) same_kind.push_back(si->name);
    std::string msg = std::string(s.key) + ".type: unknown stage '" + type + "'";
    const std::string near = nearest(type, same_kind);
    if (!near.empty()) msg += " (did you mean '" + near + "'?)";
    errors.push_back(msg);
    return nullptr;
  }
  if (info->kind != s.kind) {
    errors.push_back(std::string(s.key) + ".type: '" + type + "' is a " + to_string(info->kind) +
                     " stage, not one of " + to_string(s.kind));
    return nullptr;
  }
  return info;
}

/// Parses stage section s of cfg into sc (section, type, options) and records its effective
/// options and input files in pc; problems go to errors (sc then stays partly filled).
void parse_stage_section(Registry& reg, const Section& s, const json& cfg, const std::string& origin, StageConfig& sc,
                         PipelineConfig& pc, std::vector<std::string>& errors) {
  sc.section = s.key;
  const json node = cfg.contains(s.key) ? cfg[s.key] : json::object();
  if (!node.is_object()) {
    errors.push_back(origin + ": '" + s.key + "' must be an object like {\"type\": \"" + s.default_type + "\"}");
    return;
  }
  if (node.contains("type") && !node["type"].is_string()) {
    errors.push_back(std::string(s.key) + ".type: must be a string naming a stage");
    return;
  }
  sc.type = node.value("type", std::string(s.default_type));
  const StageInfo* info = find_section_stage(reg, s, sc.type, errors);
  if (!info) return;
  sc.options = make_options(*info, node, std::string(s.key) + " (" + sc.type + ")", errors);
  json eff = sc.options.values();
  eff["type"] = sc.type;
  pc.effective[s.key] = eff;
  for (const OptionSpec& o : info->options)
    if (o.type == OptionType::InputPath && !sc.options.get_string(o.key).empty())
      pc.input_files.push_back(sc.options.get_string(o.key));
}

/// Parses the framework's sections (texture, output) of cfg into pc, checks output.name and
/// records their effective options and the description in pc.effective.
void parse_framework_sections(const json& cfg, PipelineConfig& pc, std::vector<std::string>& errors) {
  pc.texture = make_options(texture_stage_info(), cfg.value("texture", json::object()), "texture", errors);
  pc.output = make_options(writer_stage_info(), cfg.value("output", json::object()), "output", errors);
  if (pc.output.values().contains("name")) {
    const std::string name = pc.output.get_string("name");
    const std::string problem = name.empty() ? "" : file_stem_problem(name);
    if (!problem.empty())
      errors.push_back("output.name: '" + name + "' " + problem +
                       "; it is the stem of the output files, written inside the output folder (-o)");
  }
  pc.effective["texture"] = pc.texture.values();
  pc.effective["output"] = pc.output.values();
  if (cfg.contains("description")) pc.effective["description"] = cfg["description"];
}

}  // namespace

PipelineConfig parse_config(const json& config, const std::string& origin, const std::vector<std::string>& overrides) {
  std::vector<std::string> errors;
  if (!config.is_object()) throw ConfigError({origin + ": the configuration must be a JSON object"});
  json cfg = config;

  Registry& reg = Registry::instance();
  reg.load_plugins();

  // Overrides: "section.option=value" or "kind.stage.option=value" (stage must be the section's type).
  // "SECTION.type=X" comes first and resets the section to X with its defaults: the options of the
  // stage it replaces mean nothing to X. The other overrides then apply in order.
  for (const std::string& o : order_overrides(overrides)) apply_override(cfg, o, origin, errors);
  check_top_level_keys(cfg, origin, errors);

  PipelineConfig pc;
  pc.origin = origin;
  StageConfig* targets[] = {&pc.detector, &pc.merger, &pc.packer};
  for (size_t i = 0; i < 3; ++i) parse_stage_section(reg, kSections[i], cfg, origin, *targets[i], pc, errors);
  parse_framework_sections(cfg, pc, errors);

  // Let stages check cross-option constraints now, before any mesh is read.
  if (errors.empty()) {
    for (StageConfig* sc : targets) {
      try {
        auto st = reg.create(sc->type);
        st->set_options(sc->options);
      } catch (const std::exception& e) {
        errors.push_back(sc->section + " (" + sc->type + "): " + e.what());
      }
    }
  }
  if (!errors.empty()) throw ConfigError(errors);
  return pc;
}

PipelineConfig load_config(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError({path + ": cannot open configuration file"});
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    // Convert the byte offset to line and column.
    size_t line = 1, col = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') { ++line; col = 1; } else { ++col; }
    }
    std::string what = e.what();
    const size_t p = what.find("parse error");
    throw ConfigError({path + ":" + std::to_string(line) + ":" + std::to_string(col) + ": invalid JSON: " +
                       (p == std::string::npos ? what : what.substr(p))});
  } catch (const json::exception& e) {
    // Not a syntax error, e.g. out_of_range 406 "number overflow parsing '6e666'" (found by
    // fuzz_config): nlohmann gives no position for these, so the message names the file and the token.
    throw ConfigError({path + ": invalid JSON: " + std::string(e.what())});
  }
  return parse_config(j, path, overrides);
}

}  // namespace texdefrag
