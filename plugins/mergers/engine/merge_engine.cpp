// Seam merging with exact rollback: Liu et al. 2024, "Planar feature-preserving texture
// defragmentation method for 3D urban building models" (Remote Sensing 16(22) 4154), section 2.2
// (merge order, rigid alignment, weld, local optimisation within alpha * displacement, whole-seam
// acceptance), and Maggiordomo, Cignoni, Tarini 2021, "Texture defragmentation for
// photo-reconstructed 3D models" (the M-method's cost, refusals and acceptance tests).
#include "merge_engine.h"

#include "geometry2d.h"

#include "texdefrag/core/distortion.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <cmath>
#include <numeric>
#include <queue>
#include <unordered_map>

namespace texdefrag::merge {

std::vector<OptionSpec> merge_option_specs(double local_bound_default) {
  return {
      opt_enum("priority", "planarity", {"planarity", "mmethod"},
               "Merge order: 'planarity' = largest max(I_a,I_b)*max(area_a,area_b) first (Liu et al.); "
               "'mmethod' = smallest alignment-error cost first, with the M-method's refusals and penalty doubling"),
      opt_double("alpha", 5, "Free-region radius as a multiple of the largest weld displacement").range(0, 1000),
      opt_double("global_bound", 0.025,
                 "Reject a merge when the area-weighted ARAP distortion over all textured faces exceeds this")
          .range(0, 1e6),
      opt_double("local_bound", local_bound_default,
                 "Reject a merge when the area-weighted ARAP error of its free region exceeds this")
          .range(0, 1e6),
      opt_double("min_singular_value", 0,
                 "Reject a merge when a reshaped triangle's smaller singular value (output UV size over input UV size "
                 "along its most compressed direction) falls below this: no near-collapsed, smeared triangles (0: off, "
                 "the M-method's and the paper's behaviour)")
          .range(0, 1),
      opt_int("max_merges", 100000000, "Stop after this many accepted merges").at_least(0),
      opt_int("max_attempts", 3,
              "Attempts per chart pair; a rejected pair is retried only after one of its charts changed")
          .range(1, 1000),
      opt_int("max_free_vertices", 2000, "Largest free region of one merge (nearest wedges to the seam first)")
          .range(1, 10000000),
      opt_enum("second_pass", "none", {"none", "across_regions"},
               "After the region-constrained queue is empty: 'none' stops (Liu et al.); 'across_regions' queues every "
               "adjacent chart pair, regions ignored, and merges on with the remaining global distortion budget"),
      opt_enum("second_pass_priority", "mmethod", {"planarity", "mmethod"},
               "Merge order of the second pass (see 'priority')"),
      opt_double("second_pass_local_bound", 0.5,
                 "local_bound during the second pass (area-weighted ARAP error of the free region)")
          .range(0, 1e6),
      opt_bool("second_pass_seam_refusal", true,
               "Under the 'mmethod' order in the second pass, refuse seams shorter than 0.2 of both charts' borders "
               "(the M-method's rule); false tries them too"),
      opt_int("second_pass_steps", 1,
              "The second pass runs this many times with local bounds second_pass_local_bound / 2^(steps-1), ..., / 2, "
              "x 1 (cheap merges first); attempts are reset between steps")
          .range(1, 20),
      opt_bool("cross_page", true,
               "Merge charts whose texels lie on different input pages (each face keeps its own page's texels as "
               "rest shape); false keeps every chart on one input page"),
  };
}

MergeOptions merge_options_from(const Options& o) {
  MergeOptions m;
  m.priority = o.get_string("priority") == "mmethod" ? Priority::MMethod : Priority::Planarity;
  m.alpha = o.get_double("alpha");
  m.global_bound = o.get_double("global_bound");
  m.local_bound = o.get_double("local_bound");
  m.min_singular_value = o.get_double("min_singular_value");
  m.max_merges = o.get_int("max_merges");
  m.max_attempts = static_cast<int>(o.get_int("max_attempts"));
  m.max_free_vertices = static_cast<int>(o.get_int("max_free_vertices"));
  m.cross_page = o.get_bool("cross_page");
  m.second_pass = o.get_string("second_pass") == "across_regions" ? SecondPass::AcrossRegions : SecondPass::None;
  m.second_pass_priority = o.get_string("second_pass_priority") == "planarity" ? Priority::Planarity : Priority::MMethod;
  m.second_pass_local_bound = o.get_double("second_pass_local_bound");
  m.second_pass_seam_refusal = o.get_bool("second_pass_seam_refusal");
  m.second_pass_steps = static_cast<int>(o.get_int("second_pass_steps"));
  return m;
}

json MergeReport::to_json() const {
  json j;
  j["charts_in"] = charts_in;
  j["charts_out"] = charts_out;
  j["locked_charts"] = locked_charts;
  j["self_overlapping_charts"] = self_overlapping_charts;
  j["candidate_pairs"] = candidates_initial;
  j["merges_attempted"] = attempted;
  j["merges_accepted"] = accepted;
  j["charts_after_first_pass"] = charts_after_first_pass;
  j["merges_accepted_second_pass"] = accepted_second_pass;
  j["distortion_after_first_pass"] = distortion_after_first_pass;
  json rej = json::object();
  size_t total = 0;
  for (const auto& [k, v] : rejected) {
    rej[k] = v;
    total += v;
  }
  j["rejected"] = rej;
  j["rejected_total"] = total;
  j["distortion_in"] = distortion_in;
  j["distortion_out"] = distortion_out;
  j["flipped_out"] = flipped_out;
  j["optimisation_seconds"] = optimisation_seconds;
  j["check_seconds"] = check_seconds;
  j["mean_free_vertices"] = mean_free_vertices;
  return j;
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// A triangle or segment spanning more cells than this goes to its grid's `big` list instead.
constexpr long long kMaxTriCells = 64;

/// Items (faces or edges) of one chart in a uniform hash grid: cell -> item ids. Each item is
/// inserted with the cell range of its box (x0, y0, x1, y1), kept by the caller for its removal.
struct CellGrid {
  std::unordered_map<long long, std::vector<int>> cells;
  std::vector<int> big;  ///< items spanning more than kMaxTriCells cells (always tested)

  /// x in the high 32 bits, y in the low ones (unsigned shift: cells can be negative).
  static long long key(long long x, long long y) {
    return static_cast<long long>((static_cast<unsigned long long>(x) << 32) ^
                                  (static_cast<unsigned long long>(y) & 0xffffffffULL));
  }
  /// Inserts `id` over the cells of r; an item spanning too many cells goes to `big` and r becomes
  /// the empty range.
  void insert(int id, std::array<int, 4>& r) {
    if (static_cast<long long>(r[2] - r[0] + 1) * (r[3] - r[1] + 1) > kMaxTriCells) {
      r = {1, 1, 0, 0};
      big.push_back(id);
      return;
    }
    for (int y = r[1]; y <= r[3]; ++y)
      for (int x = r[0]; x <= r[2]; ++x) cells[key(x, y)].push_back(id);
  }
  /// Removes `id`, inserted with range r.
  void remove(int id, const std::array<int, 4>& r) {
    auto drop = [id](std::vector<int>& v) {
      auto it = std::find(v.begin(), v.end(), id);
      if (it != v.end()) {
        *it = v.back();
        v.pop_back();
      }
    };
    if (r[0] > r[2]) drop(big);
    for (int y = r[1]; y <= r[3]; ++y)
      for (int x = r[0]; x <= r[2]; ++x) {
        auto it = cells.find(key(x, y));
        if (it == cells.end()) continue;
        drop(it->second);
        if (it->second.empty()) cells.erase(it);
      }
  }
  void clear() {
    cells.clear();
    big.clear();
  }
  /// Calls fn(id) for every item of `big` and of every cell of the ranges rs (an item can come more
  /// than once: callers de-duplicate).
  template <class Fn>
  void query(const std::vector<std::array<int, 4>>& rs, Fn&& fn) const {
    for (int id : big) fn(id);
    for (const auto& r : rs)
      for (int y = r[1]; y <= r[3]; ++y)
        for (int x = r[0]; x <= r[2]; ++x) {
          auto it = cells.find(key(x, y));
          if (it == cells.end()) continue;
          for (int id : it->second) fn(id);
        }
  }
  /// Number of cells of range r.
  static double cell_count(const std::array<int, 4>& r) {
    return (static_cast<double>(r[2]) - r[0] + 1) * (static_cast<double>(r[3]) - r[1] + 1);
  }
};

struct ChartInfo {
  bool alive = true;
  bool locked = false;
  bool self_overlap = false;  ///< some of its triangles overlap (inherited from the input)
  int version = 0;
  int region = -1;
  int page = kNoPage;
  std::map<int, double> page_area;  ///< input UV area (texels^2) per input page of its faces
  double uv_area = 0;   ///< input UV area of its faces (texels^2): stable under optimisation
  double border = 0;    ///< current UV border length (texels)
  double planarity = 0; ///< cached index for the current version
  Moments mom;
  std::vector<int> faces;
  /// Boundary edges (face, local edge) in the order they became part of this chart; entries whose
  /// edge is no longer a boundary edge (ebnd_ == 0) are tombstones, compacted in order when they
  /// outnumber the live ones (the M-method's border sum adds the live entries in this order).
  std::vector<std::pair<int, int>> boundary;
  size_t boundary_dead = 0;
  CellGrid segs;  ///< its live boundary segments (current positions), edge ids 3f+k
  std::unordered_map<int, std::vector<int>> adj;       ///< neighbour chart -> seam edge ids
  CellGrid tris;  ///< its triangles with input UV area > 0 (current positions)
};

/// Merges the M-method's island lookahead may look ahead (its IslandLookahead(a, b, 5)).
constexpr int kIslandLookaheadSteps = 5;


struct Entry {
  double score;  ///< larger first
  int a, b;      ///< a < b
  int va, vb;    ///< chart versions when scored
  int refusal;   ///< 0 none, 1 seam_too_short, 2 alignment_error
  bool operator<(const Entry& o) const { return score < o.score; }
};

const char* kRefusal[] = {"", "seam_too_short", "alignment_error"};

class Engine {
 public:
  Engine(const TexturedMesh& mesh, const Topology& topo, Atlas& at, const std::vector<int>& face_region,
         const MergeOptions& opt, LocalSolver& solver)
      : mesh_(mesh), topo_(topo), at_(at), region_(face_region), opt_(opt), solver_(solver) {}

  MergeReport run(const Progress& progress);

 private:
  // ---- static data
  void setup();
  int corner_of(int f, int v) const {
    const auto& fv = topo_.face_vertex[static_cast<size_t>(f)];
    for (int i = 0; i < 3; ++i)
      if (fv[static_cast<size_t>(i)] == v) return i;
    return -1;
  }
  Vec2& uv(int w) { return at_.wedge_uv[static_cast<size_t>(w)]; }
  Tri2 tri2(int f) const {
    Tri2 t;
    for (int k = 0; k < 3; ++k) {
      t.w[static_cast<size_t>(k)] = wedge(f, k);
      t.p[static_cast<size_t>(k)] = at_.wedge_uv[static_cast<size_t>(wedge(f, k))];
    }
    return t;
  }
  int wedge(int f, int k) const { return at_.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)]; }
  int chart(int f) const { return at_.face_chart[static_cast<size_t>(f)]; }
  ChartInfo& C(int c) { return charts_[static_cast<size_t>(c)]; }
  Mat2 jacobian(int f) const;
  double weighted_err(int f) const;
  bool is_boundary(int f, int k, int c) const;
  double edge_uv_len(int f, int k) const;
  /// True when the faces of chart c around wedge w wrap: angle sum >= 2 pi at a boundary wedge,
  /// > 2 pi at an interior one (a single closed fan has exactly 2 pi, up to rounding).
  bool fan_overlaps(int w, int c) const;
  template <class Fn>
  void faces_of_wedge(int w, int c, Fn&& fn) const;

  // ---- queue
  void refresh_planarity(int c);
  void push_pair(int a, int b);
  double score(int a, int b, int& refusal);
  /// The M-method's exception to its short-seam refusal: true when a sequence of at most max_steps
  /// merges involving a and b can close a UV island, i.e. for some neighbour c of a or b, the charts
  /// reachable from a without passing through c are found within max_steps pushes of a depth-first
  /// visit (so they form an island whose only neighbour is c). False at once when a or b has more
  /// than max_steps neighbours.
  bool island_lookahead(int a, int b, int max_steps) const;
  bool candidate(int a, int b) const;
  void pair_points(int big, int small, std::vector<std::pair<int, int>>& pairs);

  // ---- one move
  bool try_merge(int a, int b, std::string& reason);
  void rollback();

  const TexturedMesh& mesh_;
  const Topology& topo_;
  Atlas& at_;
  const std::vector<int>& region_;
  MergeOptions opt_;   ///< priority and local_bound switch to the second pass's values when it starts
  bool across_ = false;  ///< second pass: regions are ignored
  void drain(const Progress& progress, double base, double span);
  void start_second_pass(double local_bound);
  LocalSolver& solver_;
  MergeReport rep_;

  std::vector<int> vf_off_, vf_;       ///< welded vertex -> textured faces (CSR)
  std::vector<Mat2> rest_inv_;
  std::vector<double> rest_w_;         ///< input UV area (0: no energy)
  std::vector<double> err_w_;          ///< weight * ARAP error, per face, current atlas
  double err_sum_ = 0, weight_sum_ = 0;
  std::vector<Vec3> region_normal_;
  std::vector<ChartInfo> charts_;
  std::priority_queue<Entry> queue_;
  struct PairState {
    int attempts = 0;
    double penalty = 1;        ///< the M-method's penalty, doubled on each rejection
    int va = -1, vb = -1;      ///< versions of the newest queue entry of this pair
  };
  std::unordered_map<long long, PairState> pairs_;
  PairState& pair_state(int a, int b) {
    return pairs_[static_cast<long long>(std::min(a, b)) << 32 | static_cast<long long>(std::max(a, b))];
  }
  std::vector<double> refreshed_area_;  ///< uv_area of a chart when all its pairs were last re-pushed
  double free_total_ = 0;
  size_t free_count_ = 0;

  // ---- per-move scratch with epoch stamps
  int epoch_ = 0;
  std::vector<int> wstamp_, wmoved_, wrep_, wvisit_, wdone_, wfan_, fstamp_, fchanged_;
  std::vector<double> wdist_;
  // ---- per-chart triangle grids (cell size tri_cell_, shared by all charts)
  double tri_cell_ = 1;
  std::vector<int> fowner_;                 ///< chart whose grid holds face f (-1: none)
  std::vector<std::array<int, 4>> fcells_;  ///< cell range x0, y0, x1, y1 it was inserted with
  std::vector<int> fseen_;                  ///< query stamps
  int seen_stamp_ = 0;
  void tri_box(int f, Vec2& lo, Vec2& hi) const {
    lo = hi = at_.wedge_uv[static_cast<size_t>(wedge(f, 0))];
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(at_.wedge_uv[static_cast<size_t>(wedge(f, k))]);
      hi = hi.cwiseMax(at_.wedge_uv[static_cast<size_t>(wedge(f, k))]);
    }
  }
  int cell_of(double x) const {
    const double q = std::floor(x / tri_cell_);
    return static_cast<int>(std::max(-1e9, std::min(1e9, q)));
  }
  /// Cell range of a grid query for the box [lo, hi] of an item of size len, widened by more than
  /// the overlap tests' touching tolerance (1e-7 x the longest edge of a pair).
  std::array<int, 4> query_cells(const Vec2& lo, const Vec2& hi, double len) const {
    const double margin = 1e-6 * len + 1e-4 * tri_cell_;
    return {cell_of(lo.x() - margin), cell_of(lo.y() - margin), cell_of(hi.x() + margin), cell_of(hi.y() + margin)};
  }
  void grid_insert(int c, int f);
  void grid_remove(int f);
  // ---- per-chart boundary-segment grids (same cells as the triangle grids); edge id e = 3f + k
  std::vector<char> ebnd_;                  ///< edge e is a live boundary edge of chart(f)
  std::vector<int> eowner_;                 ///< chart whose segment grid holds edge e (-1: none)
  std::vector<std::array<int, 4>> ecells_;  ///< cell range it was inserted with
  std::vector<int> edead_, emoved_, eseen_; ///< per-move stamps (epoch_, seen_stamp_)
  void seg_insert(int c, int e);
  void seg_remove(int e);
  void compact_boundary(ChartInfo& ch);
  std::vector<std::pair<int, Vec2>> saved_uv_;
  std::vector<std::pair<int, std::array<int, 3>>> saved_fw_;
  int saved_small_ = -1;
  void save_uv(int w) {
    if (wstamp_[static_cast<size_t>(w)] == epoch_) return;
    wstamp_[static_cast<size_t>(w)] = epoch_;
    saved_uv_.emplace_back(w, uv(w));
  }
};

void Engine::setup() {
  const size_t nf = mesh_.faces.size();
  if (at_.face_chart.size() != nf || at_.face_wedge.size() != nf)
    throw std::invalid_argument("merge engine: atlas does not match the mesh");
  if (!region_.empty() && region_.size() != nf)
    throw std::invalid_argument("merge engine: face_region has " + std::to_string(region_.size()) +
                                " entries for " + std::to_string(nf) + " faces");
  // Vertex -> faces.
  vf_off_.assign(topo_.num_vertices() + 1, 0);
  for (size_t f = 0; f < nf; ++f)
    if (at_.face_chart[f] >= 0)
      for (int v : topo_.face_vertex[f]) ++vf_off_[static_cast<size_t>(v) + 1];
  std::partial_sum(vf_off_.begin(), vf_off_.end(), vf_off_.begin());
  vf_.assign(static_cast<size_t>(vf_off_.back()), 0);
  std::vector<int> fill(vf_off_.begin(), vf_off_.end() - 1);
  for (size_t f = 0; f < nf; ++f)
    if (at_.face_chart[f] >= 0)
      for (int v : topo_.face_vertex[f]) {
        // note: a degenerate face lists a vertex twice; keep one entry.
        const size_t s = static_cast<size_t>(vf_off_[static_cast<size_t>(v)]);
        const size_t e = static_cast<size_t>(fill[static_cast<size_t>(v)]);
        if (e > s && vf_[e - 1] == static_cast<int>(f)) continue;
        vf_[e] = static_cast<int>(f);
        ++fill[static_cast<size_t>(v)];
      }
  // Rest shapes.
  rest_inv_.assign(nf, Mat2::Identity());
  rest_w_.assign(nf, 0);
  err_w_.assign(nf, 0);
  for (size_t f = 0; f < nf; ++f) {
    if (at_.face_chart[f] < 0) continue;
    Mat2 Dm;
    Dm.col(0) = mesh_.corner_texel(f, 1) - mesh_.corner_texel(f, 0);
    Dm.col(1) = mesh_.corner_texel(f, 2) - mesh_.corner_texel(f, 0);
    const double det = Dm.determinant();
    if (det == 0 || !std::isfinite(det) || topo_.face_degenerate[f]) continue;
    rest_inv_[f] = Dm.inverse();
    rest_w_[f] = 0.5 * std::abs(det);
    weight_sum_ += rest_w_[f];
  }
  for (size_t f = 0; f < nf; ++f) {
    if (rest_w_[f] == 0) continue;
    err_w_[f] = weighted_err(static_cast<int>(f));
    err_sum_ += err_w_[f];
  }
  rep_.distortion_in = weight_sum_ > 0 ? err_sum_ / weight_sum_ : 0;

  // Charts.
  const int nc = at_.num_charts;
  rep_.charts_in = static_cast<size_t>(nc);
  charts_.assign(static_cast<size_t>(nc), {});
  Vec3 origin = Vec3::Zero();
  if (!mesh_.positions.empty()) {
    for (const Vec3& p : mesh_.positions) origin += p;
    origin /= static_cast<double>(mesh_.positions.size());
  }
  int nregions = 1;
  for (int r : region_) nregions = std::max(nregions, r + 1);
  std::vector<Moments> rmom(static_cast<size_t>(nregions));
  ebnd_.assign(3 * nf, 0);
  std::vector<std::map<int, int>> votes(static_cast<size_t>(nc));
  for (size_t f = 0; f < nf; ++f) {
    const int c = at_.face_chart[f];
    if (c < 0) continue;
    ChartInfo& ch = C(c);
    ch.page = at_.chart_page[static_cast<size_t>(c)];
    ch.faces.push_back(static_cast<int>(f));
    ch.uv_area += rest_w_[f];
    ch.page_area[mesh_.faces[f].page] += rest_w_[f];
    if (topo_.face_degenerate[f]) ch.locked = true;
    Moments m;
    m.add_triangle(mesh_.corner_position(f, 0) - origin, mesh_.corner_position(f, 1) - origin,
                   mesh_.corner_position(f, 2) - origin);
    ch.mom.add(m);
    const int r = region_.empty() ? 0 : region_[f];
    if (r >= 0) {
      ++votes[static_cast<size_t>(c)][r];
      rmom[static_cast<size_t>(r)].add(m);
    }
    for (int k = 0; k < 3; ++k)
      if (is_boundary(static_cast<int>(f), k, c)) {
        ch.boundary.emplace_back(static_cast<int>(f), k);
        ch.border += edge_uv_len(static_cast<int>(f), k);
        ebnd_[3 * f + static_cast<size_t>(k)] = 1;
      }
  }
  region_normal_.assign(static_cast<size_t>(nregions), Vec3::Zero());
  for (size_t r = 0; r < rmom.size(); ++r) {
    Eigen::Vector3d ev;
    rmom[r].plane(ev, region_normal_[r]);
  }
  for (int c = 0; c < nc; ++c) {
    ChartInfo& ch = C(c);
    int best = -1, bestn = 0;
    for (const auto& [r, n] : votes[static_cast<size_t>(c)])
      if (n > bestn) {
        best = r;
        bestn = n;
      }
    ch.region = best;
    if (ch.locked) ++rep_.locked_charts;
    refresh_planarity(c);
  }
  // Input charts whose triangles already overlap (photogrammetry charts can be multi-sheeted): the
  // boundary-crossing test does not see a merge that lands on another sheet, so merges touching
  // them also test triangles (see try_merge).
  for (int c = 0; c < nc; ++c) {
    ChartInfo& ch = C(c);
    if (ch.faces.size() < 2) continue;
    std::vector<Tri2> tris;
    tris.reserve(ch.faces.size());
    for (int f : ch.faces)
      if (rest_w_[static_cast<size_t>(f)] > 0) tris.push_back(tri2(f));
    ch.self_overlap = any_triangle_overlap(tris, {});
    if (ch.self_overlap) ++rep_.self_overlapping_charts;
  }
  // Seam edges: manifold, two textured non-degenerate faces in different charts.
  for (size_t ei = 0; ei < topo_.edges.size(); ++ei) {
    const Edge& e = topo_.edges[ei];
    if (e.num_faces != 2 || e.a == e.b) continue;
    const EdgeIncidence& x = topo_.edge_faces[static_cast<size_t>(e.first_incidence)];
    const EdgeIncidence& y = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
    const int ca = chart(x.face), cb = chart(y.face);
    if (ca < 0 || cb < 0 || ca == cb) continue;
    if (topo_.face_degenerate[static_cast<size_t>(x.face)] || topo_.face_degenerate[static_cast<size_t>(y.face)])
      continue;
    C(ca).adj[cb].push_back(static_cast<int>(ei));
    C(cb).adj[ca].push_back(static_cast<int>(ei));
  }
  wstamp_.assign(at_.wedge_uv.size(), 0);
  wmoved_.assign(at_.wedge_uv.size(), 0);
  wdist_.assign(at_.wedge_uv.size(), 0);
  wvisit_.assign(at_.wedge_uv.size(), 0);
  wfan_.assign(at_.wedge_uv.size(), 0);
  wrep_.assign(at_.wedge_uv.size(), 0);
  wdone_.assign(at_.wedge_uv.size(), 0);
  fstamp_.assign(nf, 0);
  fchanged_.assign(nf, 0);
  // Triangle grids: cell = twice the mean longest UV edge of the textured faces.
  fowner_.assign(nf, -1);
  fcells_.assign(nf, {1, 1, 0, 0});
  fseen_.assign(nf, 0);
  {
    double sum = 0;
    size_t n = 0;
    for (size_t f = 0; f < nf; ++f) {
      if (rest_w_[f] == 0) continue;
      Vec2 lo, hi;
      tri_box(static_cast<int>(f), lo, hi);
      const double e = (hi - lo).maxCoeff();
      if (std::isfinite(e)) {
        sum += e;
        ++n;
      }
    }
    tri_cell_ = n > 0 && sum > 0 ? 2 * sum / static_cast<double>(n) : 1;
  }
  for (size_t f = 0; f < nf; ++f)
    if (rest_w_[f] > 0 && at_.face_chart[f] >= 0) grid_insert(at_.face_chart[f], static_cast<int>(f));
  eowner_.assign(3 * nf, -1);
  ecells_.assign(3 * nf, {1, 1, 0, 0});
  edead_.assign(3 * nf, 0);
  emoved_.assign(3 * nf, 0);
  eseen_.assign(3 * nf, 0);
  for (int c = 0; c < nc; ++c)
    for (const auto& [f, k] : C(c).boundary) seg_insert(c, 3 * f + k);
}

Mat2 Engine::jacobian(int f) const {
  Mat2 B;
  const Vec2& a = at_.wedge_uv[static_cast<size_t>(wedge(f, 0))];
  B.col(0) = at_.wedge_uv[static_cast<size_t>(wedge(f, 1))] - a;
  B.col(1) = at_.wedge_uv[static_cast<size_t>(wedge(f, 2))] - a;
  return B * rest_inv_[static_cast<size_t>(f)];
}

double Engine::weighted_err(int f) const {
  const double w = rest_w_[static_cast<size_t>(f)];
  return w == 0 ? 0.0 : w * arap_error_2x2(jacobian(f));
}

bool Engine::is_boundary(int f, int k, int c) const {
  const Edge& e = topo_.edges[static_cast<size_t>(topo_.face_edge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
  const int w0 = wedge(f, k), w1 = wedge(f, (k + 1) % 3);
  for (int i = 0; i < e.num_faces; ++i) {
    const EdgeIncidence& in = topo_.edge_faces[static_cast<size_t>(e.first_incidence + i)];
    if (in.face == f || chart(in.face) != c) continue;
    const int g0 = wedge(in.face, in.local), g1 = wedge(in.face, (in.local + 1) % 3);
    if ((w0 == g0 && w1 == g1) || (w0 == g1 && w1 == g0)) return false;
  }
  return true;
}

bool Engine::fan_overlaps(int w, int c) const {
  double sum = 0;
  bool boundary = false;
  faces_of_wedge(w, c, [&](int f, int k) {
    const Vec2& p = at_.wedge_uv[static_cast<size_t>(wedge(f, k))];
    const Vec2 a = at_.wedge_uv[static_cast<size_t>(wedge(f, (k + 1) % 3))] - p;
    const Vec2 b = at_.wedge_uv[static_cast<size_t>(wedge(f, (k + 2) % 3))] - p;
    sum += std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)));
    if (!boundary && (is_boundary(f, k, c) || is_boundary(f, (k + 2) % 3, c))) boundary = true;
  });
  constexpr double kTwoPi = 6.283185307179586;
  return boundary ? sum >= kTwoPi * (1 - 1e-9) : sum > kTwoPi * (1 + 1e-9);
}

double Engine::edge_uv_len(int f, int k) const {
  return (at_.wedge_uv[static_cast<size_t>(wedge(f, k))] - at_.wedge_uv[static_cast<size_t>(wedge(f, (k + 1) % 3))]).norm();
}

template <class Fn>
void Engine::faces_of_wedge(int w, int c, Fn&& fn) const {
  const int v = at_.wedge_vertex[static_cast<size_t>(w)];
  for (int i = vf_off_[static_cast<size_t>(v)]; i < vf_off_[static_cast<size_t>(v) + 1]; ++i) {
    const int f = vf_[static_cast<size_t>(i)];
    if (chart(f) != c) continue;
    for (int k = 0; k < 3; ++k)
      if (wedge(f, k) == w) {
        fn(f, k);
        break;
      }
  }
}

void Engine::refresh_planarity(int c) {
  ChartInfo& ch = C(c);
  Eigen::Vector3d ev, n;
  ch.mom.plane(ev, n);
  const Vec3 rn = ch.region >= 0 ? region_normal_[static_cast<size_t>(ch.region)] : Vec3::Zero();
  ch.planarity = ch.mom.area > 0 ? planarity_index(ev, n, rn, opt_.weights) : 0.0;
}

bool Engine::candidate(int a, int b) const {
  const ChartInfo& A = charts_[static_cast<size_t>(a)];
  const ChartInfo& B = charts_[static_cast<size_t>(b)];
  return a != b && A.alive && B.alive && !A.locked && !B.locked && (opt_.cross_page || A.page == B.page) &&
         (across_ || (A.region >= 0 && A.region == B.region));
}

void Engine::pair_points(int big, int small, std::vector<std::pair<int, int>>& pairs) {
  pairs.clear();
  for (int ei : C(big).adj[small]) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    EdgeIncidence x = topo_.edge_faces[static_cast<size_t>(e.first_incidence)];
    EdgeIncidence y = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
    if (chart(x.face) != big) std::swap(x, y);
    for (int v : {e.a, e.b}) {
      const int kf = corner_of(x.face, v), kg = corner_of(y.face, v);
      pairs.emplace_back(wedge(x.face, kf), wedge(y.face, kg));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
}

bool Engine::island_lookahead(int a, int b, int max_steps) const {
  const ChartInfo& A = charts_[static_cast<size_t>(a)];
  const ChartInfo& B = charts_[static_cast<size_t>(b)];
  if (A.adj.size() > static_cast<size_t>(max_steps) || B.adj.size() > static_cast<size_t>(max_steps)) return false;
  auto sorted_neighbours = [&](int c) {
    std::vector<int> n;
    for (const auto& kv : charts_[static_cast<size_t>(c)].adj) n.push_back(kv.first);
    std::sort(n.begin(), n.end());
    return n;
  };
  std::vector<int> nab = sorted_neighbours(a);
  for (int c : sorted_neighbours(b)) nab.push_back(c);
  std::sort(nab.begin(), nab.end());
  nab.erase(std::unique(nab.begin(), nab.end()), nab.end());
  for (int c : nab) {
    std::vector<int> stack{a}, visited{c, a};
    int steps = 0;
    auto seen = [&](int x) { return std::find(visited.begin(), visited.end(), x) != visited.end(); };
    while (!stack.empty() && steps <= max_steps) {
      const int sc = stack.back();
      stack.pop_back();
      if (!seen(sc)) visited.push_back(sc);
      for (int ac : sorted_neighbours(sc)) {
        if (!seen(ac)) {
          stack.push_back(ac);
          ++steps;
        }
        if (steps > max_steps) break;
      }
    }
    if (stack.empty()) return true;  // the component of a without c has c as its only neighbour
  }
  return false;
}

double Engine::score(int a, int b, int& refusal) {
  ChartInfo& A = C(a);
  ChartInfo& B = C(b);
  refusal = 0;
  if (opt_.priority == Priority::Planarity)
    return std::max(A.planarity, B.planarity) * std::max(A.uv_area, B.uv_area);
  // M-method cost: err * min(B_a/L_a, B_b/L_b) * min(area_a, area_b) * penalty, smaller first.
  const int big = A.uv_area >= B.uv_area ? a : b, small = big == a ? b : a;
  std::vector<std::pair<int, int>> pairs;
  pair_points(big, small, pairs);
  std::vector<Vec2> p, q;
  for (const auto& [wb, ws] : pairs) {
    q.push_back(uv(wb));
    p.push_back(uv(ws));
  }
  const Rigid2 m = fit_rigid(p, q);
  double err = 0;
  for (size_t i = 0; i < p.size(); ++i) err += (m(p[i]) - q[i]).norm();
  err /= static_cast<double>(std::max<size_t>(1, p.size()));
  double la = 0, lb = 0;
  size_t nedges = 0;
  for (int ei : A.adj[b]) {
    const Edge& ed = topo_.edges[static_cast<size_t>(ei)];
    for (int i = 0; i < 2; ++i) {
      const EdgeIncidence& in = topo_.edge_faces[static_cast<size_t>(ed.first_incidence + i)];
      (chart(in.face) == a ? la : lb) += edge_uv_len(in.face, in.local);
    }
    ++nedges;
  }
  const double ra = la > 0 ? A.border / la : 1e30, rb = lb > 0 ? B.border / lb : 1e30;
  const double cost = err * std::min(ra, rb) * std::min(A.uv_area, B.uv_area) * pair_state(a, b).penalty;
  const double mean_seam = nedges ? 0.5 * (la + lb) / static_cast<double>(nedges) : 0;
  if (la < 0.2 * A.border && lb < 0.2 * B.border && !(across_ && !opt_.second_pass_seam_refusal) &&
      !island_lookahead(a, b, kIslandLookaheadSteps))
    refusal = 1;
  else if (err > 2 * mean_seam)
    refusal = 2;
  return -cost;
}

void Engine::push_pair(int a, int b) {
  if (a > b) std::swap(a, b);
  if (!candidate(a, b)) return;
  PairState& ps = pair_state(a, b);
  if (ps.attempts >= opt_.max_attempts) return;
  if (ps.va == C(a).version && ps.vb == C(b).version) return;  // its newest entry is current
  Entry e{0, a, b, C(a).version, C(b).version, 0};
  e.score = score(a, b, e.refusal);
  ps.va = e.va;
  ps.vb = e.vb;
  queue_.push(e);
}

void Engine::rollback() {
  for (auto it = saved_uv_.rbegin(); it != saved_uv_.rend(); ++it) uv(it->first) = it->second;
  for (auto it = saved_fw_.rbegin(); it != saved_fw_.rend(); ++it)
    at_.face_wedge[static_cast<size_t>(it->first)] = it->second;
  for (int f : C(saved_small_).faces) at_.face_chart[static_cast<size_t>(f)] = saved_small_;
}

void Engine::grid_insert(int c, int f) {
  Vec2 lo, hi;
  tri_box(f, lo, hi);
  std::array<int, 4>& r = fcells_[static_cast<size_t>(f)];
  r = {cell_of(lo.x()), cell_of(lo.y()), cell_of(hi.x()), cell_of(hi.y())};
  fowner_[static_cast<size_t>(f)] = c;
  C(c).tris.insert(f, r);
}

void Engine::seg_insert(int c, int e) {
  const Vec2& a = uv(wedge(e / 3, e % 3));
  const Vec2& b = uv(wedge(e / 3, (e % 3 + 1) % 3));
  std::array<int, 4>& r = ecells_[static_cast<size_t>(e)];
  r = {cell_of(std::min(a.x(), b.x())), cell_of(std::min(a.y(), b.y())), cell_of(std::max(a.x(), b.x())),
       cell_of(std::max(a.y(), b.y()))};
  eowner_[static_cast<size_t>(e)] = c;
  C(c).segs.insert(e, r);
}

void Engine::seg_remove(int e) {
  const int c = eowner_[static_cast<size_t>(e)];
  if (c < 0) return;
  C(c).segs.remove(e, ecells_[static_cast<size_t>(e)]);
  eowner_[static_cast<size_t>(e)] = -1;
}

void Engine::compact_boundary(ChartInfo& ch) {
  if (2 * ch.boundary_dead <= ch.boundary.size()) return;
  size_t n = 0;
  for (const auto& fk : ch.boundary)
    if (ebnd_[3 * static_cast<size_t>(fk.first) + static_cast<size_t>(fk.second)]) ch.boundary[n++] = fk;
  ch.boundary.resize(n);
  ch.boundary_dead = 0;
}

void Engine::grid_remove(int f) {
  const int c = fowner_[static_cast<size_t>(f)];
  if (c < 0) return;
  C(c).tris.remove(f, fcells_[static_cast<size_t>(f)]);
  fowner_[static_cast<size_t>(f)] = -1;
}

bool Engine::try_merge(int a, int b, std::string& reason) {
  ++epoch_;
  ++rep_.attempted;
  saved_uv_.clear();
  saved_fw_.clear();
  const int big = C(a).uv_area >= C(b).uv_area ? a : b, small = big == a ? b : a;
  ChartInfo& Bg = C(big);
  ChartInfo& Sm = C(small);
  saved_small_ = small;
  std::vector<std::pair<int, int>> pairs;
  pair_points(big, small, pairs);
  std::vector<int> seam_edges = Bg.adj[small];

  // 1. Rigid alignment of the smaller chart.
  std::vector<Vec2> p, q;
  for (const auto& [wb, ws] : pairs) {
    q.push_back(uv(wb));
    p.push_back(uv(ws));
  }
  const Rigid2 m = fit_rigid(p, q);
  std::vector<int> small_wedges;
  for (int f : Sm.faces)
    for (int k = 0; k < 3; ++k) {
      const int w = wedge(f, k);
      if (wstamp_[static_cast<size_t>(w)] == epoch_) continue;
      save_uv(w);
      small_wedges.push_back(w);
      wmoved_[static_cast<size_t>(w)] = epoch_;
      uv(w) = m(uv(w));
    }

  // 2. Weld: union the pairs, each group to its mean; representative = a wedge of the bigger chart.
  std::unordered_map<int, int> parent;
  auto find = [&](int x) {
    auto it = parent.find(x);
    if (it == parent.end()) {
      parent[x] = x;
      return x;
    }
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& [wb, ws] : pairs) {
    const int rb = find(wb), rs = find(ws);
    if (rb != rs) parent[std::max(rb, rs)] = std::min(rb, rs);
  }
  std::unordered_map<int, std::vector<int>> groups;
  for (const auto& [w, par] : parent) {
    (void)par;
    groups[find(w)].push_back(w);
  }
  std::unordered_map<int, int> rep_of;
  std::vector<int> reps;
  double dmax = 0;
  std::unordered_map<int, char> is_big;
  for (const auto& pr : pairs) is_big[pr.first] = 1;
  for (auto& [root, members] : groups) {
    (void)root;
    std::sort(members.begin(), members.end());
    // Representative: the smallest wedge of the bigger chart in the group.
    int r = -1;
    for (int w : members)
      if (is_big.count(w)) {
        r = w;
        break;
      }
    Vec2 mean = Vec2::Zero();
    for (int w : members) mean += uv(w);
    mean /= static_cast<double>(members.size());
    for (int w : members) {
      dmax = std::max(dmax, (uv(w) - mean).norm());
      save_uv(w);
      wmoved_[static_cast<size_t>(w)] = epoch_;
      uv(w) = mean;
      rep_of[w] = r;
    }
    reps.push_back(r);
    wrep_[static_cast<size_t>(r)] = epoch_;
  }
  // Repoint corners of both charts at the welded vertices.
  for (const auto& [root, members] : groups) {
    (void)root;
    const int v = at_.wedge_vertex[static_cast<size_t>(members.front())];
    for (int i = vf_off_[static_cast<size_t>(v)]; i < vf_off_[static_cast<size_t>(v) + 1]; ++i) {
      const int f = vf_[static_cast<size_t>(i)];
      const int c = chart(f);
      if (c != big && c != small) continue;
      for (int k = 0; k < 3; ++k) {
        auto it = rep_of.find(wedge(f, k));
        if (it == rep_of.end() || it->second == wedge(f, k)) continue;
        if (fstamp_[static_cast<size_t>(f)] != epoch_) {
          fstamp_[static_cast<size_t>(f)] = epoch_;
          saved_fw_.emplace_back(f, at_.face_wedge[static_cast<size_t>(f)]);
        }
        at_.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)] = it->second;
      }
    }
  }
  for (int f : Sm.faces) at_.face_chart[static_cast<size_t>(f)] = big;

  // Seam folds: the two faces of a welded edge must lie on opposite sides of it.
  auto folded = [&](int ei) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    double s[2];
    for (int i = 0; i < 2; ++i) {
      const EdgeIncidence& in = topo_.edge_faces[static_cast<size_t>(e.first_incidence + i)];
      const int f = in.face, k = in.local;
      s[i] = orient2d(uv(wedge(f, 0)), uv(wedge(f, 1)), uv(wedge(f, 2)));
      // Same-sidedness of the opposite corners <=> equal orientation along opposite traversal.
      const bool forward = topo_.face_vertex[static_cast<size_t>(f)][static_cast<size_t>(k)] == e.a;
      if (!forward) s[i] = -s[i];
    }
    // Traversed a->b, face 0's third corner is on side sign(s0); face 1's on side sign(s1).
    return !(s[0] * s[1] < 0);
  };
  size_t nfold = 0;
  for (int ei : seam_edges) nfold += folded(ei) ? 1 : 0;
  if (2 * nfold > seam_edges.size()) {
    reason = "orientation";
    rollback();
    return false;
  }

  // 3. Free region: Dijkstra over UV edge lengths from the welded wedges, radius alpha * dmax.
  const double radius = opt_.alpha * dmax;
  std::vector<int> free_w;
  {
    using QE = std::pair<double, int>;
    std::priority_queue<QE, std::vector<QE>, std::greater<QE>> pq;
    auto dist = [&](int w) -> double& {
      if (wvisit_[static_cast<size_t>(w)] != epoch_) {
        wvisit_[static_cast<size_t>(w)] = epoch_;
        wdist_[static_cast<size_t>(w)] = std::numeric_limits<double>::infinity();
      }
      return wdist_[static_cast<size_t>(w)];
    };
    for (int r : reps) {
      dist(r) = 0;
      pq.emplace(0.0, r);
    }
    while (!pq.empty() && static_cast<int>(free_w.size()) < opt_.max_free_vertices) {
      const auto [d, w] = pq.top();
      pq.pop();
      if (wdone_[static_cast<size_t>(w)] == epoch_ || d > dist(w)) continue;
      wdone_[static_cast<size_t>(w)] = epoch_;
      if (d > radius) break;
      bool pinned = false;
      faces_of_wedge(w, big, [&](int f, int) {
        if (rest_w_[static_cast<size_t>(f)] == 0) pinned = true;
      });
      if (pinned) continue;
      free_w.push_back(w);
      faces_of_wedge(w, big, [&](int f, int k) {
        for (int j = 1; j < 3; ++j) {
          const int u = wedge(f, (k + j) % 3);
          const double nd = d + (uv(u) - uv(w)).norm();
          if (nd < dist(u)) {
            dist(u) = nd;
            pq.emplace(nd, u);
          }
        }
      });
    }
  }

  // 4. Build and solve the local problem.
  LocalProblem lp;
  std::unordered_map<int, int> local;
  for (int w : free_w) {
    local[w] = static_cast<int>(lp.x.size());
    lp.x.push_back(uv(w));
  }
  lp.num_free = static_cast<int>(lp.x.size());
  std::vector<int> prob_faces;
  for (int w : free_w)
    faces_of_wedge(w, big, [&](int f, int) {
      if (fchanged_[static_cast<size_t>(f)] == epoch_) return;
      fchanged_[static_cast<size_t>(f)] = epoch_;
      prob_faces.push_back(f);
    });
  for (int f : prob_faces)
    for (int k = 0; k < 3; ++k)
      if (!local.count(wedge(f, k))) {
        local[wedge(f, k)] = static_cast<int>(lp.x.size());
        lp.x.push_back(uv(wedge(f, k)));
      }
  if (lp.num_free > 0 && static_cast<int>(lp.x.size()) == lp.num_free) {
    // The whole chart is free: pin the farthest free wedge so rigid motions are fixed.
    --lp.num_free;
  }
  for (int f : prob_faces) {
    lp.tri.push_back({local[wedge(f, 0)], local[wedge(f, 1)], local[wedge(f, 2)]});
    lp.rest_inv.push_back(rest_inv_[static_cast<size_t>(f)]);
    lp.weight.push_back(rest_w_[static_cast<size_t>(f)]);
  }
  free_total_ += lp.num_free;
  ++free_count_;
  const auto t0 = Clock::now();
  const SolveResult sr = solver_.solve(lp);
  rep_.optimisation_seconds += seconds_since(t0);
  for (int i = 0; i < lp.num_free; ++i) {
    const int w = free_w[static_cast<size_t>(i)];
    save_uv(w);
    wmoved_[static_cast<size_t>(w)] = epoch_;
    uv(w) = lp.x[static_cast<size_t>(i)];
  }
  const auto t1 = Clock::now();
  struct CheckTimer {
    double& acc;
    Clock::time_point t;
    ~CheckTimer() { acc += seconds_since(t); }
  } timer{rep_.check_seconds, t1};

  // 5. Acceptance tests, cheapest first.
  // Faces whose shape changed (beyond the rigid motion): those around moved seam/free wedges.
  std::vector<int> changed = prob_faces;
  for (int r : reps)
    faces_of_wedge(r, big, [&](int f, int) {
      if (fchanged_[static_cast<size_t>(f)] == epoch_) return;
      fchanged_[static_cast<size_t>(f)] = epoch_;
      changed.push_back(f);
    });
  if (!sr.ok) {
    reason = "flip";
    rollback();
    return false;
  }
  // Flips first (any flipped face makes the reason "flip"), then near-collapsed faces.
  bool collapsed = false;
  for (int f : changed) {
    if (rest_w_[static_cast<size_t>(f)] == 0) continue;
    const Mat2 J = jacobian(f);
    if (J.determinant() <= 0) {
      reason = "flip";
      rollback();
      return false;
    }
    if (opt_.min_singular_value > 0 && !collapsed)
      collapsed = signed_singular_values_2x2(J)[1] < opt_.min_singular_value;
  }
  if (collapsed) {
    reason = "collapse";
    rollback();
    return false;
  }
  for (int ei : seam_edges)
    if (folded(ei)) {
      reason = "fold";
      rollback();
      return false;
    }
  std::vector<double> new_err(changed.size());
  double delta = 0, lsum = 0, lw = 0;
  for (size_t i = 0; i < changed.size(); ++i) {
    const int f = changed[i];
    new_err[i] = weighted_err(f);
    delta += new_err[i] - err_w_[static_cast<size_t>(f)];
    lsum += new_err[i];
    lw += rest_w_[static_cast<size_t>(f)];
  }
  if (lw > 0 && lsum / lw > opt_.local_bound) {
    reason = "local_distortion";
    rollback();
    return false;
  }
  const double new_sum = err_sum_ + delta;
  if (weight_sum_ > 0 && new_sum / weight_sum_ > opt_.global_bound) {
    reason = "global_distortion";
    rollback();
    return false;
  }
  // Fans: the triangles around a wedge must not wrap over each other. Boundary segments that share
  // a wedge are never tested for crossing, so a boundary wedge whose incident angles add up to 2 pi
  // or more (the merge nearly closed a fan whose input angles exceed 2 pi) overlaps without any
  // crossing; an interior wedge must have exactly 2 pi (more: a pinch of two fans, or a multiple cover).
  for (int f : changed)
    for (int k = 0; k < 3; ++k) {
      const int w = wedge(f, k);
      if (wfan_[static_cast<size_t>(w)] == epoch_) continue;
      wfan_[static_cast<size_t>(w)] = epoch_;
      if (fan_overlaps(w, big)) {
        reason = "fan_overlap";
        rollback();
        return false;
      }
    }
  // Self-overlap of the merged chart: its moved boundary segments against its other boundary
  // segments. Only edges with a welded (representative) wedge can stop being boundary edges; only
  // edges of the smaller chart and of the changed faces can have moved. The other segments come from
  // the bigger chart's segment grid, queried with the moved segments' boxes, so the test costs
  // O(moved segments + segments near them), not O(boundary).
  std::vector<int> dead;        // live boundary edges the weld made interior (applied on accept)
  std::vector<int> moved_ids;   // live boundary edges with a moved wedge
  auto consider = [&](int f) {
    for (int k = 0; k < 3; ++k) {
      const int e = 3 * f + k;
      if (!ebnd_[static_cast<size_t>(e)] || emoved_[static_cast<size_t>(e)] == epoch_ ||
          edead_[static_cast<size_t>(e)] == epoch_)
        continue;
      const int w0 = wedge(f, k), w1 = wedge(f, (k + 1) % 3);
      if ((wrep_[static_cast<size_t>(w0)] == epoch_ || wrep_[static_cast<size_t>(w1)] == epoch_) &&
          !is_boundary(f, k, big)) {
        edead_[static_cast<size_t>(e)] = epoch_;
        dead.push_back(e);
        continue;
      }
      if (wmoved_[static_cast<size_t>(w0)] == epoch_ || wmoved_[static_cast<size_t>(w1)] == epoch_) {
        emoved_[static_cast<size_t>(e)] = epoch_;
        moved_ids.push_back(e);
      }
    }
  };
  for (const auto& fk : Sm.boundary)
    if (ebnd_[3 * static_cast<size_t>(fk.first) + static_cast<size_t>(fk.second)]) consider(fk.first);
  for (int f : changed) consider(f);
  for (int r : reps) faces_of_wedge(r, big, [&](int f, int) { consider(f); });
  std::vector<Segment> all, moved;
  auto segment = [&](int e) {
    Segment sg;
    sg.w0 = wedge(e / 3, e % 3);
    sg.w1 = wedge(e / 3, (e % 3 + 1) % 3);
    sg.a = uv(sg.w0);
    sg.b = uv(sg.w1);
    return sg;
  };
  moved.reserve(moved_ids.size());
  for (int e : moved_ids) moved.push_back(segment(e));
  {
    ++seen_stamp_;
    auto visit = [&](int e) {
      if (eseen_[static_cast<size_t>(e)] == seen_stamp_) return;
      eseen_[static_cast<size_t>(e)] = seen_stamp_;
      if (!ebnd_[static_cast<size_t>(e)] || emoved_[static_cast<size_t>(e)] == epoch_ ||
          edead_[static_cast<size_t>(e)] == epoch_)
        return;
      all.push_back(segment(e));
    };
    // The smaller chart's unmoved segments (none after a rigid alignment, kept for safety).
    for (const auto& [f, k] : Sm.boundary) visit(3 * f + k);
    if (!moved.empty()) {
      std::vector<std::array<int, 4>> qr;
      qr.reserve(moved.size());
      double ncells = 0;
      for (const Segment& sg : moved) {
        qr.push_back(query_cells(sg.a.cwiseMin(sg.b), sg.a.cwiseMax(sg.b), (sg.b - sg.a).norm()));
        ncells += CellGrid::cell_count(qr.back());
      }
      if (ncells > static_cast<double>(Bg.boundary.size())) {
        for (const auto& [f, k] : Bg.boundary) visit(3 * f + k);
      } else {
        Bg.segs.query(qr, visit);
      }
    }
  }
  if (any_crossing(moved, all)) {
    reason = "overlap";
    rollback();
    return false;
  }

  // Triangles: every moved or changed triangle against every other triangle of the merged chart.
  // The boundary and fan tests above miss overlaps that neither cross a boundary nor wrap a fan seen
  // by this merge: another sheet of a multi-sheeted input chart, or a chart whose fan the earlier
  // merges closed around a wedge with input angles far above 2 pi (t078_L15: a 1-face chart welded
  // onto a 4 pi double cover). Pairs of unchanged triangles keep their relative positions (the
  // bigger chart's stay put, the smaller chart's move rigidly together), so testing every pair with
  // a moved triangle means no merge adds an overlapping pair.
  // note: conservative: an input overlap among the moved triangles also rejects the merge.
  {
    std::vector<Tri2> mt, rest;
    Vec2 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()), hi = -lo;
    auto grow = [&](const Tri2& t) {
      for (const Vec2& q : t.p) {
        lo = lo.cwiseMin(q);
        hi = hi.cwiseMax(q);
      }
    };
    for (int f : Sm.faces)
      if (rest_w_[static_cast<size_t>(f)] > 0) {
        mt.push_back(tri2(f));
        grow(mt.back());
      }
    // The bigger chart's changed faces (every face with fchanged_ == epoch_ is in `changed`).
    for (int f : changed)
      if (rest_w_[static_cast<size_t>(f)] > 0 && fowner_[static_cast<size_t>(f)] == big) {
        mt.push_back(tri2(f));
        grow(mt.back());
      }
    // Only the bigger chart's unchanged triangles whose box meets the moved triangles' box can overlap
    // them. Candidates come from its triangle grid, queried with each moved triangle's box widened by
    // more than triangles_overlap's touching tolerance (1e-7 x the longest edge of the pair; grid
    // triangles span at most kMaxTriCells cells); when the query would visit more cells than the chart
    // has faces, scan the faces instead.
    auto keep = [&](int f) {
      if (fchanged_[static_cast<size_t>(f)] == epoch_ || rest_w_[static_cast<size_t>(f)] == 0) return;
      const Vec2& a = uv(wedge(f, 0));
      const Vec2& b = uv(wedge(f, 1));
      const Vec2& c = uv(wedge(f, 2));
      if (std::max({a.x(), b.x(), c.x()}) < lo.x() || std::min({a.x(), b.x(), c.x()}) > hi.x() ||
          std::max({a.y(), b.y(), c.y()}) < lo.y() || std::min({a.y(), b.y(), c.y()}) > hi.y())
        return;
      rest.push_back(tri2(f));
    };
    std::vector<std::array<int, 4>> qr;
    qr.reserve(mt.size());
    double ncells = 0;
    for (const Tri2& t : mt) {
      Vec2 a = t.p[0], b = t.p[0];
      double l = 0;
      for (int k = 0; k < 3; ++k) {
        a = a.cwiseMin(t.p[static_cast<size_t>(k)]);
        b = b.cwiseMax(t.p[static_cast<size_t>(k)]);
        l = std::max(l, (t.p[static_cast<size_t>(k)] - t.p[static_cast<size_t>((k + 1) % 3)]).norm());
      }
      qr.push_back(query_cells(a, b, l));
      ncells += CellGrid::cell_count(qr.back());
    }
    if (ncells > static_cast<double>(Bg.faces.size())) {
      for (int f : Bg.faces) keep(f);
    } else {
      ++seen_stamp_;
      auto visit = [&](int f) {
        if (fseen_[static_cast<size_t>(f)] == seen_stamp_) return;
        fseen_[static_cast<size_t>(f)] = seen_stamp_;
        keep(f);
      };
      Bg.tris.query(qr, visit);
    }
    if (any_triangle_overlap(mt, rest)) {
      reason = "overlap";
      rollback();
      return false;
    }
  }

  // Accept: commit distortion, chart data and adjacency.
  for (size_t i = 0; i < changed.size(); ++i) err_w_[static_cast<size_t>(changed[i])] = new_err[i];
  err_sum_ = new_sum;
  for (int f : changed)
    if (fowner_[static_cast<size_t>(f)] == big) grid_remove(f);
  for (int f : Sm.faces) fowner_[static_cast<size_t>(f)] = -1;
  Sm.tris.clear();
  for (int f : Sm.faces)
    if (rest_w_[static_cast<size_t>(f)] > 0) grid_insert(big, f);
  for (int f : changed)
    if (rest_w_[static_cast<size_t>(f)] > 0 && fowner_[static_cast<size_t>(f)] != big) grid_insert(big, f);
  Bg.faces.insert(Bg.faces.end(), Sm.faces.begin(), Sm.faces.end());
  Sm.faces.clear();
  Sm.faces.shrink_to_fit();
  // Boundary: the weld's interior edges die; moved segments are re-gridded; the smaller chart's
  // live edges are appended in their order.
  for (int e : dead) {
    if (eowner_[static_cast<size_t>(e)] == big) ++Bg.boundary_dead;  // a tombstone in Bg.boundary
    ebnd_[static_cast<size_t>(e)] = 0;
    seg_remove(e);
  }
  for (int e : moved_ids) {
    seg_remove(e);
    seg_insert(big, e);
  }
  for (const auto& [f, k] : Sm.boundary) {
    const int e = 3 * f + k;
    if (!ebnd_[static_cast<size_t>(e)]) continue;
    if (eowner_[static_cast<size_t>(e)] != big) {
      seg_remove(e);
      seg_insert(big, e);
    }
    Bg.boundary.emplace_back(f, k);
  }
  Sm.boundary.clear();
  Sm.boundary_dead = 0;
  Sm.segs.clear();
  compact_boundary(Bg);
  if (opt_.priority == Priority::MMethod) {  // the border length is used by its cost only
    Bg.border = 0;
    for (const auto& [f, k] : Bg.boundary)
      if (ebnd_[3 * static_cast<size_t>(f) + static_cast<size_t>(k)]) Bg.border += edge_uv_len(f, k);
  }
  Bg.mom.add(Sm.mom);
  Bg.self_overlap = Bg.self_overlap || Sm.self_overlap;
  Bg.uv_area += Sm.uv_area;
  for (const auto& [pg, ar] : Sm.page_area) Bg.page_area[pg] += ar;
  Sm.page_area.clear();
  if (Bg.page != Sm.page) {
    // The chart's page = the page with the most input UV area (ties: the lower page id).
    double best = -1;
    for (const auto& [pg, ar] : Bg.page_area)
      if (ar > best) {
        best = ar;
        Bg.page = pg;
      }
    at_.chart_page[static_cast<size_t>(big)] = Bg.page;
  }
  Sm.alive = false;
  ++Sm.version;
  ++Bg.version;
  Bg.adj.erase(small);
  for (auto& [c, edges] : Sm.adj) {
    if (c == big) continue;
    auto& to = Bg.adj[c];
    to.insert(to.end(), edges.begin(), edges.end());
    auto& back = C(c).adj;
    auto& tb = back[big];
    tb.insert(tb.end(), edges.begin(), edges.end());
    back.erase(small);
  }
  Sm.adj.clear();
  refresh_planarity(big);
  return true;
}

MergeReport Engine::run(const Progress& progress) {
  setup();
  for (int c = 0; c < at_.num_charts; ++c)
    for (const auto& [n, edges] : C(c).adj)
      if (c < n && candidate(c, n)) {
        ++rep_.candidates_initial;
        push_pair(c, n);
      }
  refreshed_area_.resize(charts_.size());
  for (size_t c = 0; c < charts_.size(); ++c) refreshed_area_[c] = charts_[c].uv_area;
  const bool second = opt_.second_pass == SecondPass::AcrossRegions;
  drain(progress, 0, second ? 0.6 : 1.0);
  rep_.charts_after_first_pass = 0;
  for (const ChartInfo& ch : charts_) rep_.charts_after_first_pass += ch.alive && !ch.faces.empty();
  rep_.distortion_after_first_pass = weight_sum_ > 0 ? err_sum_ / weight_sum_ : 0;
  if (second) {
    const size_t before = rep_.accepted;
    const int steps = std::max(1, opt_.second_pass_steps);
    for (int i = 0; i < steps; ++i) {
      start_second_pass(opt_.second_pass_local_bound / std::pow(2.0, steps - 1 - i));
      drain(progress, 0.6 + 0.4 * i / steps, 0.4 / steps);
    }
    rep_.accepted_second_pass = rep_.accepted - before;
  }
  if (progress) progress(1.0);
  rep_.mean_free_vertices = free_count_ ? free_total_ / static_cast<double>(free_count_) : 0;
  rep_.charts_out = static_cast<size_t>(at_.compact());
  const DistortionSummary ds = atlas_distortion(mesh_, at_);
  rep_.distortion_out = ds.arap;
  rep_.flipped_out = ds.flipped;
  return rep_;
}

void Engine::start_second_pass(double local_bound) {
  // Regions are ignored from now on; the order and the per-merge bound switch to the second pass's.
  const bool first_step = !across_;
  across_ = true;
  opt_.priority = opt_.second_pass_priority;
  opt_.local_bound = local_bound;
  // The M-method's cost needs every chart's current border length (kept only under that order).
  for (ChartInfo& ch : charts_) {
    if (!ch.alive) continue;
    ch.border = 0;
    for (const auto& [f, k] : ch.boundary)
      if (ebnd_[3 * static_cast<size_t>(f) + static_cast<size_t>(k)]) ch.border += edge_uv_len(f, k);
  }
  // Every adjacent pair is queued again under the new order (pairs that used up max_attempts stay out).
  for (auto& [key, ps] : pairs_) {
    ps.va = ps.vb = -1;
    if (!first_step) ps.attempts = 0;  // a later step has a looser local bound: try again
  }
  for (int c = 0; c < static_cast<int>(charts_.size()); ++c) {
    if (!C(c).alive) continue;
    std::vector<int> nb;
    for (const auto& [n, edges] : C(c).adj)
      if (c < n) nb.push_back(n);
    for (int n : nb) push_pair(c, n);
  }
}

void Engine::drain(const Progress& progress, double base, double span) {
  size_t popped = 0;
  while (!queue_.empty() && static_cast<long long>(rep_.accepted) < opt_.max_merges) {
    const Entry e = queue_.top();
    queue_.pop();
    if ((++popped & 255) == 0 && progress)
      progress(base + span * static_cast<double>(popped) / static_cast<double>(popped + queue_.size()));
    if (!C(e.a).alive || !C(e.b).alive) continue;
    if (C(e.a).version != e.va || C(e.b).version != e.vb) {
      // note: lazy refresh: a stale entry is re-scored and queued again (once per version pair).
      push_pair(e.a, e.b);
      continue;
    }
    PairState& ps = pair_state(e.a, e.b);
    if (ps.attempts >= opt_.max_attempts) continue;
    ++ps.attempts;
    if (e.refusal) {
      ++rep_.rejected[kRefusal[e.refusal]];
      continue;
    }
    std::string reason;
    // note: take the small chart's neighbour list before the merge consumes it.
    const int big0 = C(e.a).uv_area >= C(e.b).uv_area ? e.a : e.b, small0 = big0 == e.a ? e.b : e.a;
    std::vector<int> fresh;
    for (const auto& [n, edges] : C(small0).adj)
      if (n != big0 && !C(big0).adj.count(n)) fresh.push_back(n);
    if (try_merge(e.a, e.b, reason)) {
      ++rep_.accepted;
      const int big = big0;
      ChartInfo& B = C(big);
      // Re-queue every pair of the merged chart when its area grew by a quarter since the last
      // full refresh (scores move little before that; stale entries are re-scored when popped);
      // always queue the pairs it inherited from the absorbed chart.
      if (B.uv_area > 1.25 * refreshed_area_[static_cast<size_t>(big)] || opt_.priority == Priority::MMethod) {
        refreshed_area_[static_cast<size_t>(big)] = B.uv_area;
        std::vector<int> nb;
        for (const auto& [n, edges] : B.adj) nb.push_back(n);
        for (int n : nb) push_pair(big, n);
      } else {
        for (int n : fresh) push_pair(big, n);
      }
    } else {
      ++rep_.rejected[reason];
      ps.penalty *= 2;  // the M-method's penalty (used by its cost only)
    }
  }
}

}  // namespace

MergeReport run_merges(const TexturedMesh& mesh, const Topology& topo, Atlas& atlas, const std::vector<int>& face_region,
                       const MergeOptions& opt, LocalSolver& solver, const Progress& progress) {
  Engine e(mesh, topo, atlas, face_region, opt, solver);
  return e.run(progress);
}

void run_merge_stage(StageContext& ctx, const std::string& stage, const MergeOptions& opt, LocalSolver& solver) {
  if (!ctx.mesh || !ctx.topology) throw StageError(stage + ": the context has no mesh or topology");
  const TexturedMesh& mesh = *ctx.mesh;
  if (ctx.atlas.face_chart.size() != mesh.faces.size())
    throw StageError(stage + ": the atlas has " + std::to_string(ctx.atlas.face_chart.size()) + " faces, the mesh " +
                     std::to_string(mesh.faces.size()));
  const auto& fr = ctx.regions.face_region;
  if (!fr.empty() && fr.size() != mesh.faces.size())
    throw StageError(stage + ": the detector's regions cover " + std::to_string(fr.size()) + " faces, the mesh has " +
                     std::to_string(mesh.faces.size()));
  for (size_t f = 0; f < fr.size(); ++f)
    if (fr[f] >= ctx.regions.num_regions)
      throw StageError(stage + ": face " + std::to_string(f) + " has region " + std::to_string(fr[f]) +
                       " outside [0, " + std::to_string(ctx.regions.num_regions) + ")");
  for (size_t p = 0; p < mesh.pages.size(); ++p)
    if (mesh.pages[p].width <= 0 || mesh.pages[p].height <= 0)
      throw StageError(stage + ": page " + std::to_string(p) + " has no known size");
  const MergeReport r =
      run_merges(mesh, *ctx.topology, ctx.atlas, fr, opt, solver, [&](double f) { ctx.step(stage, f); });
  if (ctx.report) {
    json j = r.to_json();
    for (auto it = j.begin(); it != j.end(); ++it) (*ctx.report)[it.key()] = it.value();
  }
}

}  // namespace texdefrag::merge
