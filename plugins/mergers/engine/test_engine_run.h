// One engine set up on a hand-built mesh, shared by the engine's step tests (cuts, holes). Include
// after test_support.h; the engine's own tests only (it needs the engine's internal header).
#pragma once

#include "arap_solver.h"
#include "engine_internal.h"
#include "test_support.h"

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

}  // namespace texdefrag::merge::test
