// Stage declarations as JSON (texdefrag plugins --json, Python texdefrag.stages()).
#include "texdefrag/stage/describe.h"

#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"

namespace texdefrag {

json describe_stage(const StageInfo& info, const std::string& source) {
  json opts = json::array();
  for (const OptionSpec& o : info.options) {
    json j = {{"key", o.key}, {"type", to_string(o.type)}, {"default", o.default_value}, {"help", o.help}};
    if (o.min) j["min"] = *o.min;
    if (o.max) j["max"] = *o.max;
    if (!o.choices.empty()) j["choices"] = o.choices;
    if (!o.unit.empty()) j["unit"] = o.unit;
    opts.push_back(j);
  }
  return {{"name", info.name}, {"kind", to_string(info.kind)}, {"description", info.description}, {"doc", info.doc},
          {"source", source}, {"options", opts}};
}

json describe_all_stages() {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  json all = json::array();
  for (const StageInfo* i : reg.list()) all.push_back(describe_stage(*i, reg.source_of(i->name)));
  all.push_back(describe_stage(texture_stage_info(), "framework"));
  all.push_back(describe_stage(writer_stage_info(), "framework"));
  return all;
}

}  // namespace texdefrag
