// Shared parts of the model-format fuzz targets (fuzz_gltf, fuzz_osgb, fuzz_tiles3d; docs/io.md
// "Fuzzing"): what a reader may throw, and the mesh analysis every model that reads must pass.
#pragma once

#include "fuzz_image.h"  // finding, work_dir

#include "texdefrag/core/charts.h"
#include "texdefrag/core/distortion.h"
#include "texdefrag/core/topology.h"

#include <string>

namespace texdefrag::fuzz {

/// A reader's error must name the file: its message starts with `prefix` (the input's path, or the
/// folder holding it and the files it names). Else a finding.
inline void expect_named(const char* target, const std::string& message, const std::string& prefix) {
  if (message.rfind(prefix, 0) != 0) finding(target, "error does not start with '" + prefix + "': " + message);
}

/// A mesh a reader returned is analysed without error: every face index in range, then topology,
/// charts, chart statistics and distortion (as the pipeline's first steps do).
inline void analyse(const char* target, const TexturedMesh& mesh) {
  for (const Face& f : mesh.faces)
    for (size_t k = 0; k < 3; ++k) {
      if (f.v[k] < 0 || static_cast<size_t>(f.v[k]) >= mesh.positions.size()) finding(target, "face position index out of range");
      if (f.vt[k] >= 0 && static_cast<size_t>(f.vt[k]) >= mesh.texcoords.size()) finding(target, "face texcoord index out of range");
      if (f.page != kNoPage && (f.page < 0 || static_cast<size_t>(f.page) >= mesh.pages.size())) finding(target, "face page out of range");
    }
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  (void)chart_stats(mesh, topo, charts.atlas);
  (void)atlas_distortion(mesh, charts.atlas);
}

}  // namespace texdefrag::fuzz
