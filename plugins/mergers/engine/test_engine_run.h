// One engine set up on a hand-built mesh, shared by the engine's step tests (cuts, holes), and the
// smallest singular value of an atlas. Include after test_support.h; the engine's own tests only (it
// needs the engine's internal header).
#pragma once

#include "arap_solver.h"
#include "engine_internal.h"
#include "test_support.h"

#include <algorithm>
#include <set>
#include <utility>

namespace texdefrag::merge::test {

/// The mesh's charts (one region for every face), an ARAP solver with default settings and an
/// engine on them, set up: ready for try_merge, hole_loops, close_cuts...
struct EngineRun {
  Run run;
  ArapSolver solver{ArapSettings{}};
  detail::Engine engine;
  explicit EngineRun(TexturedMesh m, const MergeOptions& opt = {})
      : run(std::move(m)), engine(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, opt, solver) {
    engine.setup();
  }
  /// Distinct wedges the faces use.
  size_t wedges() const {
    std::set<int> w;
    for (const auto& fw : run.ctx.atlas.face_wedge) w.insert(fw.begin(), fw.end());
    return w.size();
  }
};

/// The smallest singular value of any face's map from its input UV triangle (texels) to its atlas
/// triangle: below 1 where the atlas compresses a face in some direction (min_singular_value).
inline double smallest_singular_value(const Run& run) {
  double smin = 1e9;
  for (size_t f = 0; f < run.mesh.faces.size(); ++f) {
    const auto& fw = run.ctx.atlas.face_wedge[f];
    auto at = [&](int k) { return run.ctx.atlas.wedge_uv[static_cast<size_t>(fw[static_cast<size_t>(k)])]; };
    Mat2 Dm, Do;
    Dm.col(0) = run.mesh.corner_texel(f, 1) - run.mesh.corner_texel(f, 0);
    Dm.col(1) = run.mesh.corner_texel(f, 2) - run.mesh.corner_texel(f, 0);
    Do.col(0) = at(1) - at(0);
    Do.col(1) = at(2) - at(0);
    smin = std::min(smin, signed_singular_values_2x2(Do * Dm.inverse())[1]);
  }
  return smin;
}

}  // namespace texdefrag::merge::test
