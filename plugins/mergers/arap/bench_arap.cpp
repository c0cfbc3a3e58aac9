// Benchmark: mergers.arap's two ARAP solvers (Eigen local/global prefactored once per problem, Ceres
// Levenberg-Marquardt with sparse normal Cholesky) on
// - the local problems a real merge run hands to its solver (recorded once from an M-method run
//   with the Eigen solver on t015_L18, then each solver solves copies of the same problems), split
//   by free-region size;
// - whole real tiles (the engine with each solver, M-method order, defaults);
// - the first pass's regions side by side (docs/mergers.md, "Parallel first pass"): t016_L19 with one
//   region per dominant normal axis, best.json's merger options, 1 and 2 threads.
// - the unconstrained trial beside the run with regions or after it (docs/speed.md, "The
//   unconstrained trial beside the run with regions"): t078_L17 and t016_L19, 2 threads;
// - the local problems best.json's merger hands to its solver on t016_L19 (normal-axis regions, one
//   thread), solved again by the solver best.json configures (injectivity repair on, floor 0.2): all
//   of them and those whose repair runs, with a checksum of every solution (the label), so a faster
//   solver can be shown to give the same bits.
// Run: bench_mergers_arap [--benchmark_filter=...]. Real data absent: the cases skip with an error.
#include "arap_solver.h"
#include "ceres_arap_solver.h"
#include "merge_engine.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/parallel.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace texdefrag::merge {
namespace {

/// Passes problems on to another solver, keeping a copy of each as it was handed over.
class RecordingSolver final : public LocalSolver {
 public:
  explicit RecordingSolver(LocalSolver& inner) : inner_(inner) {}
  SolveResult solve(LocalProblem& p) override {
    problems.push_back(p);
    return inner_.solve(p);
  }
  std::vector<LocalProblem> problems;

 private:
  LocalSolver& inner_;
};

const TexturedMesh& tile(const std::string& rel) {
  static std::map<std::string, TexturedMesh> cache;
  auto it = cache.find(rel);
  if (it == cache.end()) {
    const std::string p = texdefrag::testing::shared_data(rel);
    it = cache.emplace(rel, p.empty() ? TexturedMesh{} : read_obj(p)).first;
  }
  return it->second;
}
const char* const kT015 = "contextcapture/prod5_t015_L18/t015_L18.obj";
const char* const kT016L19 = "contextcapture/prod5_t016_L19/t016_L19.obj";
const char* const kT078L17 = "contextcapture/rural_t007_078_L17/t078_L17.obj";

/// The local problems of an M-method run (Eigen solver) on t015_L18, in the order they were posed.
const std::vector<LocalProblem>& recorded_problems() {
  static const std::vector<LocalProblem> probs = [] {
    const TexturedMesh& m = tile(kT015);
    if (m.faces.empty()) return std::vector<LocalProblem>{};
    const Topology topo = build_topology(m);
    Atlas at = build_charts(m, topo).atlas;
    ArapSolver eigen;
    RecordingSolver rec(eigen);
    MergeOptions o;
    o.priority = Priority::MMethod;
    run_merges(m, topo, at, {}, o, rec, {});
    return std::move(rec.problems);
  }();
  return probs;
}

/// Free-region size buckets: [lo, hi) free positions.
constexpr int kBucket[][2] = {{1, 1000000000}, {1, 5}, {5, 20}, {20, 1000000000}};

template <class Make>
void solve_recorded(benchmark::State& state, Make make) {
  const auto& all = recorded_problems();
  if (all.empty()) return state.SkipWithError("shared data absent (t015_L18)");
  const int lo = kBucket[state.range(0)][0], hi = kBucket[state.range(0)][1];
  std::vector<const LocalProblem*> probs;
  double free_sum = 0;
  for (const LocalProblem& p : all)
    if (p.num_free >= lo && p.num_free < hi) {
      probs.push_back(&p);
      free_sum += p.num_free;
    }
  if (probs.empty()) return state.SkipWithError("no recorded problem in this size bucket");
  std::unique_ptr<LocalSolver> solver = make();
  double energy = 0, iterations = 0, seconds = 0;
  size_t not_ok = 0, runs = 0;
  for (auto _ : state) {
    const std::clock_t t0 = std::clock();
    energy = 0;
    iterations = 0;
    not_ok = 0;
    for (const LocalProblem* p : probs) {
      LocalProblem q = *p;
      const SolveResult r = solver->solve(q);
      energy += r.energy;
      iterations += r.iterations;
      not_ok += r.ok ? 0 : 1;
    }
    seconds += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
    ++runs;
  }
  const double n = static_cast<double>(probs.size());
  state.counters["problems"] = n;
  state.counters["mean_free"] = free_sum / n;
  state.counters["mean_E"] = energy / n;  // mean over problems of the final area-weighted ARAP energy
  state.counters["mean_iters"] = iterations / n;
  state.counters["not_ok"] = static_cast<double>(not_ok);
  state.counters["cpu_us_per_problem"] = 1e6 * seconds / (n * static_cast<double>(runs));
}

std::unique_ptr<LocalSolver> eigen_solver() { return std::make_unique<ArapSolver>(); }
std::unique_ptr<LocalSolver> ceres_suitesparse() { return std::make_unique<CeresArapSolver>(); }
std::unique_ptr<LocalSolver> ceres_eigensparse() {
  CeresArapSettings s;
  s.sparse_library = CeresSparseLibrary::EigenSparse;
  return std::make_unique<CeresArapSolver>(s);
}

std::unique_ptr<LocalSolver> ceres_dense() {
  CeresArapSettings s;
  s.linear_solver = CeresLinearSolver::DenseNormalCholesky;
  return std::make_unique<CeresArapSolver>(s);
}

void BM_LocalEigen(benchmark::State& s) { solve_recorded(s, eigen_solver); }
void BM_LocalCeresDense(benchmark::State& s) { solve_recorded(s, ceres_dense); }
void BM_LocalCeresSuiteSparse(benchmark::State& s) { solve_recorded(s, ceres_suitesparse); }
void BM_LocalCeresEigenSparse(benchmark::State& s) { solve_recorded(s, ceres_eigensparse); }

// Energy against time: every recorded problem, iteration cap = the argument (tolerance 1e-6).
void BM_LocalEigenIterations(benchmark::State& s) {
  solve_recorded(s, [&s]() -> std::unique_ptr<LocalSolver> {
    ArapSettings a;
    a.iterations = static_cast<int>(s.range(1));
    return std::make_unique<ArapSolver>(a);
  });
}
void BM_LocalCeresIterations(benchmark::State& s) {
  solve_recorded(s, [&s]() -> std::unique_ptr<LocalSolver> {
    CeresArapSettings c;
    c.iterations = static_cast<int>(s.range(1));
    return std::make_unique<CeresArapSolver>(c);
  });
}

void whole_tile(benchmark::State& state, const char* rel, std::unique_ptr<LocalSolver> (*make)()) {
  const TexturedMesh& m = tile(rel);
  if (m.faces.empty()) return state.SkipWithError("shared data absent");
  const Topology topo = build_topology(m);
  const ChartSet cs = build_charts(m, topo);
  MergeReport r;
  for (auto _ : state) {
    Atlas at = cs.atlas;
    std::unique_ptr<LocalSolver> solver = make();
    MergeOptions o;
    o.priority = Priority::MMethod;
    r = run_merges(m, topo, at, {}, o, *solver, {});
    benchmark::DoNotOptimize(at.num_charts);
  }
  state.counters["faces"] = static_cast<double>(m.faces.size());
  state.counters["charts_in"] = static_cast<double>(r.charts_in);
  state.counters["charts_out"] = static_cast<double>(r.charts_out);
  state.counters["accepted"] = static_cast<double>(r.accepted);
  state.counters["attempted"] = static_cast<double>(r.attempted);
  state.counters["E"] = r.distortion_out;
  state.counters["opt_s"] = r.optimisation_seconds;
  state.counters["check_s"] = r.check_seconds;
  state.counters["flip_rej"] = static_cast<double>(r.rejected.count("flip") ? r.rejected.at("flip") : 0);
}

/// Region per face: the axis (and sign) its 3D normal points along most (six labels, enough lanes).
std::vector<int> normal_axis_regions(const TexturedMesh& m) {
  std::vector<int> r(m.faces.size());
  for (size_t f = 0; f < m.faces.size(); ++f) {
    const Vec3 n = (m.corner_position(f, 1) - m.corner_position(f, 0)).cross(m.corner_position(f, 2) - m.corner_position(f, 0));
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(n[k]) > std::abs(n[axis])) axis = k;
    r[f] = 2 * axis + (n[axis] < 0 ? 1 : 0);
  }
  return r;
}

/// best.json's merger options (the stage's defaults for the rest).
MergeOptions best_json_merge_options() {
  MergeOptions o;
  o.priority = Priority::MMethod;
  o.second_pass = SecondPass::AcrossRegions;
  o.second_pass_local_bound = 0.1;
  o.second_pass_seam_refusal = false;
  o.min_singular_value = 0.2;
  o.close_cuts = true;
  return o;
}

/// best.json's solver: ARAP with the injectivity repair, floor = min_singular_value.
ArapSolver best_json_solver() {
  ArapSettings a;
  a.untangle = true;
  a.singular_value_floor = 0.2;
  return ArapSolver(a);
}

/// The local problems of a best.json merge of t016_L19 (or of the OBJ named by the environment
/// variable BENCH_ARAP_MODEL), normal-axis regions, one thread, in the order they were posed.
const std::vector<LocalProblem>& best_json_problems() {
  static const std::vector<LocalProblem> probs = [] {
    const char* model = std::getenv("BENCH_ARAP_MODEL");
    static const TexturedMesh other = model ? read_obj(model) : TexturedMesh{};
    const TexturedMesh& m = model ? other : tile(kT016L19);
    if (m.faces.empty()) return std::vector<LocalProblem>{};
    const Topology topo = build_topology(m);
    Atlas at = build_charts(m, topo).atlas;
    ArapSolver solver = best_json_solver();
    RecordingSolver rec(solver);
    set_thread_count(1);
    run_merges(m, topo, at, normal_axis_regions(m), best_json_merge_options(), rec, {});
    set_thread_count(0);
    return std::move(rec.problems);
  }();
  return probs;
}

/// FNV-1a over the bytes of `n` values at `v`, continuing from h.
template <class T>
std::uint64_t fnv1a(std::uint64_t h, const T* v, size_t n) {
  const auto* b = reinterpret_cast<const unsigned char*>(v);
  for (size_t i = 0; i < n * sizeof(T); ++i) h = (h ^ b[i]) * 1099511628211ULL;
  return h;
}

// Argument: 0 = every problem, 1 = those whose plain steps end with inverted triangles (the repair
// runs). Label: checksum of every solution's positions, ok flag, iterations and energy.
void BM_BestJsonProblems(benchmark::State& state) {
  const auto& all = best_json_problems();
  if (all.empty()) return state.SkipWithError("shared data absent (t016_L19)");
  ArapSolver solver = best_json_solver();
  std::vector<const LocalProblem*> probs;
  for (const LocalProblem& p : all) {
    if (state.range(0) == 1) {
      LocalProblem q = p;
      if (!solver.solve(q).repaired) continue;
    }
    probs.push_back(&p);
  }
  std::uint64_t h = 1469598103934665603ULL;
  double seconds = 0, repaired = 0;
  for (auto _ : state) {
    h = 1469598103934665603ULL;
    repaired = 0;
    const std::clock_t t0 = std::clock();
    for (const LocalProblem* p : probs) {
      LocalProblem q = *p;
      const SolveResult r = solver.solve(q);
      h = fnv1a(h, q.x.data(), q.x.size());
      const double fig[3] = {r.ok ? 1.0 : 0.0, static_cast<double>(r.iterations), r.energy};
      h = fnv1a(h, fig, 3);
      repaired += r.repaired ? 1 : 0;
    }
    seconds += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
  }
  const double n = static_cast<double>(probs.size());
  state.counters["problems"] = n;
  state.counters["repaired"] = repaired;
  state.counters["cpu_us_per_problem"] = 1e6 * seconds / (n * static_cast<double>(state.iterations()));
  char label[32];
  std::snprintf(label, sizeof label, "sum %016llx", static_cast<unsigned long long>(h));
  state.SetLabel(label);
}

// Argument = threads. Counters: CPU seconds (all threads), wall seconds of each pass, second-pass moves
// evaluated side by side and used (docs/mergers.md, "Parallel second pass"), lanes, charts out (the
// same for any count).
void BM_RegionLanesT016L19(benchmark::State& state) {
  const TexturedMesh& m = tile(kT016L19);
  if (m.faces.empty()) return state.SkipWithError("shared data absent");
  const Topology topo = build_topology(m);
  const ChartSet cs = build_charts(m, topo);
  const std::vector<int> regions = normal_axis_regions(m);
  set_thread_count(static_cast<int>(state.range(0)));
  MergeReport r;
  const std::clock_t c0 = std::clock();
  for (auto _ : state) {
    Atlas at = cs.atlas;
    ArapSolver solver;
    MergeOptions o;  // best.json's merger options
    o.priority = Priority::MMethod;
    o.second_pass = SecondPass::AcrossRegions;
    o.second_pass_local_bound = 0.1;
    o.second_pass_seam_refusal = false;
    o.min_singular_value = 0.2;
    r = run_merges(m, topo, at, regions, o, solver, {});
    benchmark::DoNotOptimize(at.num_charts);
  }
  // note: std::clock is the process's CPU time, every thread (Linux), the figure load does not inflate.
  const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  set_thread_count(0);
  state.counters["cpu_s"] = cpu / static_cast<double>(state.iterations());
  state.counters["first_pass_s"] = r.first_pass_seconds;
  state.counters["second_pass_s"] = r.second_pass_seconds;
  state.counters["speculated"] = static_cast<double>(r.second_pass_speculated);  // second-pass moves evaluated side by side
  state.counters["spec_used"] = static_cast<double>(r.second_pass_speculation_used);
  state.counters["lanes"] = static_cast<double>(r.first_pass_lanes);
  state.counters["charts_out"] = static_cast<double>(r.charts_out);
  state.counters["E"] = r.distortion_out;
}

// Arguments: case (0 = t078_L17, 1 = t016_L19, both with best.json's share 0.95: the trial runs and is
// kept; 2 = t016_L19 with a share of 0.3, which the run with regions reaches: the trial is not
// needed), trial beside (1) or after (0); 2 threads, normal-axis regions, best.json's merger options
// with the trial on. Counters: CPU seconds (all threads), trial run / kept, beside (0 off, 1 dropped,
// 2 ended), charts out, E; the label is a checksum of the atlas (the same beside and after).
void BM_UnconstrainedTrial(benchmark::State& state) {
  const TexturedMesh& m = tile(state.range(0) == 0 ? kT078L17 : kT016L19);
  const double share = state.range(0) == 2 ? 0.3 : 0.95;
  if (m.faces.empty()) return state.SkipWithError("shared data absent");
  const Topology topo = build_topology(m);
  const ChartSet cs = build_charts(m, topo);
  const std::vector<int> regions = normal_axis_regions(m);
  set_thread_count(2);
  MergeReport r;
  Atlas at;
  const std::clock_t c0 = std::clock();
  for (auto _ : state) {
    at = cs.atlas;
    ArapSolver solver = best_json_solver();
    MergeOptions o;  // best.json's merger options
    o.priority = Priority::MMethod;
    o.second_pass = SecondPass::AcrossRegions;
    o.second_pass_local_bound = 0.1;
    o.second_pass_seam_refusal = false;
    o.min_singular_value = 0.2;
    o.close_cuts = true;
    o.unconstrained_trial = true;
    o.unconstrained_trial_share = share;
    o.unconstrained_trial_beside = state.range(1) != 0;
    r = run_merges(m, topo, at, regions, o, solver, {});
  }
  const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  set_thread_count(0);
  state.counters["cpu_s"] = cpu / static_cast<double>(state.iterations());
  state.counters["trial_run"] = r.unconstrained_trial_run ? 1 : 0;
  state.counters["trial_kept"] = r.unconstrained_trial_kept ? 1 : 0;
  state.counters["beside"] = r.unconstrained_trial_beside == "off" ? 0 : r.unconstrained_trial_beside == "dropped" ? 1 : 2;
  state.counters["charts_out"] = static_cast<double>(r.charts_out);
  state.counters["E"] = r.distortion_out;
  std::uint64_t h = fnv1a(14695981039346656037ull, at.wedge_uv.data(), at.wedge_uv.size());
  h = fnv1a(h, at.face_wedge.data(), at.face_wedge.size());
  char label[32];
  std::snprintf(label, sizeof label, "atlas %016llx", static_cast<unsigned long long>(h));
  state.SetLabel(label);
}

void BM_TileT015Eigen(benchmark::State& s) { whole_tile(s, kT015, eigen_solver); }
void BM_TileT015Ceres(benchmark::State& s) { whole_tile(s, kT015, ceres_suitesparse); }
void BM_TileT016L19Eigen(benchmark::State& s) { whole_tile(s, kT016L19, eigen_solver); }
void BM_TileT016L19Ceres(benchmark::State& s) { whole_tile(s, kT016L19, ceres_suitesparse); }

// Argument = free-region bucket: 0 all, 1 [1, 5), 2 [5, 20), 3 >= 20 free positions.
BENCHMARK(BM_LocalEigen)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_LocalCeresSuiteSparse)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_LocalCeresEigenSparse)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_LocalCeresDense)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_LocalEigenIterations)->ArgsProduct({{0}, {2, 5, 10, 20, 40}})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_LocalCeresIterations)->ArgsProduct({{0}, {1, 2, 3, 5, 10}})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_TileT015Eigen)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_TileT015Ceres)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_TileT016L19Eigen)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_TileT016L19Ceres)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_BestJsonProblems)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_RegionLanesT016L19)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_UnconstrainedTrial)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace
}  // namespace texdefrag::merge

BENCHMARK_MAIN();
