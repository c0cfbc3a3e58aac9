// A stage's declaration as JSON: what `texdefrag plugins --describe NAME --json` prints and the
// Python module's texdefrag.stages() returns.
#pragma once

#include "texdefrag/stage/stage.h"

namespace texdefrag {

/// {"name", "kind", "description", "doc", "source", "options": [{"key", "type", "default", "help",
/// "min"?, "max"?, "choices"?, "unit"?}]}. `source` is the module file (or "framework").
json describe_stage(const StageInfo& info, const std::string& source);

/// Every stage the registry knows (loading the plugins first) plus the framework's own
/// configurable steps (texture.resample, writers.obj), as describe_stage() objects, sorted by name
/// within each group.
json describe_all_stages();

}  // namespace texdefrag
