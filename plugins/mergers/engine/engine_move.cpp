// One merge move of the engine, step by step (docs/mergers.md "What one merge does", steps 3-7):
// align, weld, free region, solve, acceptance checks, commit (or rollback).
#include "engine_internal.h"

#include "texdefrag/core/distortion.h"

#include <chrono>
#include <unordered_set>
#include <functional>
#include <limits>

namespace texdefrag::merge::detail {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
/// Angle of corner k of the triangle p (radians, in [0, pi]).
double corner_angle(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 u = a - p, v = b - p;
  return std::abs(std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v)));
}
}  // namespace

bool Engine::try_merge(int a, int b, std::string& reason, Lane& L) {
  Move mv;
  if (!evaluate_merge(a, b, reason, L, mv)) return false;
  commit(mv);
  return true;
}

bool Engine::evaluate_merge(int a, int b, std::string& reason, Lane& L, Move& mv) {
  // Partial welds (docs/mergers.md step 7): a seam end whose welded fan would wrap past a turn is
  // left unwelded and the move tried again; its seam edge stays cut, a slit the fan can open into.
  std::vector<int> open;
  bool repaired = false, fill = false, hold = false;
  for (int tries = 0;; ++tries) {
    const bool ok = attempt_merge(a, b, open, fill, hold, reason, L, mv);
    mv.repaired_earlier = repaired;
    if (ok) {
      if (fill) ++L.rep.hole_fills_accepted;
      if (hold) ++L.rep.fan_holds_accepted;
      return true;
    }
    repaired = repaired || mv.repaired;
    if (opt_.hold_full_fans && !hold && !mv.self && reason == "fan_overlap" && mv.fan_wedge >= 0 && !mv.fan_welded) {
      // Held fans (docs/mergers.md, "Held fans"): the fan that wrapped is not the weld's but one of the
      // free region's, which earlier merges had closed below a turn and the solve relaxed towards its
      // input angles; the same move once more with such fans kept as they are.
      hold = true;
      --L.rep.attempted;  // note: the same move again; begin_move counts it once more
      ++L.rep.fan_hold_retries;
      continue;
    }
    if (mv.holes_refused && !fill) {
      // Hole filling (docs/mergers.md, "Hole filling"): the same move once more, its solve steered by
      // triangles across the merged chart's holes.
      fill = true;
      --L.rep.attempted;  // note: the same move again; begin_move counts it once more
      ++L.rep.hole_fill_retries;
      continue;
    }
    const int v = tries < opt_.partial_weld_tries && reason == "fan_overlap" ? open_seam_end(mv) : -1;
    if (v < 0) return false;
    open.push_back(v);
    --L.rep.attempted;  // note: the same move again; begin_move counts it once more
    ++L.rep.partial_weld_retries;
  }
}

bool Engine::attempt_merge(int a, int b, const std::vector<int>& open, bool fill, bool hold, std::string& reason,
                           Lane& L, Move& mv) {
  mv = begin_move(a, b, L);
  mv.fill_holes = fill;
  mv.hold_fans = hold;
  if (!open.empty()) leave_open(mv, open);
  align(mv);
  if (const char* why = check_orientation(mv)) {
    reason = why;
    rollback(L);
    return false;
  }
  weld(mv);
  return evaluate_welded(mv, reason, L);
}

void Engine::leave_open(Move& mv, const std::vector<int>& open) {
  auto is_open = [&](int v) { return std::find(open.begin(), open.end(), v) != open.end(); };
  std::vector<int> kept;
  for (int ei : mv.seam_edges) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    if (!is_open(e.a) && !is_open(e.b)) kept.push_back(ei);
  }
  mv.seam_edges = std::move(kept);
  seam_pairs(mv.big, mv.seam_edges, mv.pairs);
  mv.open_ends = open.size();
}

int Engine::open_seam_end(const Move& mv) const {
  // note: only an end of the welded seam: opening a vertex inside it would cut a hole in the chart,
  // and the last welded edge is kept so that the charts still share an edge (never a single vertex).
  const int w = mv.fan_wedge;
  if (w < 0 || mv.seam_edges.size() < 2 || std::find(mv.reps.begin(), mv.reps.end(), w) == mv.reps.end()) return -1;
  const int v = at_.wedge_vertex[static_cast<size_t>(w)];
  int touching = 0;
  for (int ei : mv.seam_edges) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    touching += e.a == v || e.b == v ? 1 : 0;
  }
  return touching == 1 ? v : -1;
}

bool Engine::settle_welded(Move& mv, std::string& reason, Lane& L) {
  if (!evaluate_welded(mv, reason, L)) return false;
  commit(mv);
  return true;
}

bool Engine::evaluate_welded(Move& mv, std::string& reason, Lane& L) {
  if (seam_mostly_folded(mv)) {
    reason = "orientation";
    rollback(L);
    return false;
  }
  free_region(mv);
  if (mv.hold_fans) hold_full_fans(mv);
  if (opt_.fan_targets) free_fan_rings(mv);
  solve(mv);
  if (mv.fill_failed) {
    reason = "fan_overlap";  // the first try's refusal (only fan_overlap is tried again)
    rollback(L);
    return false;
  }
  const Clock::time_point t0 = Clock::now();
  const char* why = check(mv);
  L.rep.check_seconds += seconds_since(t0);
  if (why) {
    reason = why;
    // note: fan_overlap only: on six models (ycb_banana, t016_L19, t078_L17, t015_L19p6, Cedar rooms 4
    // and 9) 36 of 1,571 such retries were accepted, 1 of 879 after flip, collapse or fold. With
    // fill_holes the fans are checked before the budget, so whether a move is tried again never
    // depends on it (a second-pass speculation's lane does not know the budget).
    mv.holes_refused = opt_.fill_holes && !mv.fill_holes && !mv.self && reason == "fan_overlap" &&
                       !hole_loops(mv).empty();
    rollback(L);
    return false;
  }
  return true;
}

Move Engine::begin_move(int a, int b, Lane& L) {
  ++L.epoch;
  ++L.rep.attempted;
  L.saved_uv.clear();
  L.saved_fw.clear();
  Move mv;
  mv.lane = &L;
  mv.big = C(a).uv_area >= C(b).uv_area ? a : b;
  mv.small = mv.big == a ? b : a;
  L.saved_small = mv.small;
  L.saved_mirrored = false;
  for (int f : C(mv.small).faces) fsmall_[static_cast<size_t>(f)] = L.epoch;
  pair_points(mv.big, mv.small, mv.pairs);
  mv.seam_edges = C(mv.big).adj[mv.small];
  return mv;
}

void Engine::align(Move& mv) {
  Lane& L = *mv.lane;
  std::vector<Vec2> p, q;
  for (const auto& [wb, ws] : mv.pairs) {
    q.push_back(uv(wb));
    p.push_back(uv(ws));
  }
  mv.mirrored = seam_mirrored(mv.big, mv.small);
  const Rigid2 m = mv.mirrored ? fit_improper(p, q) : fit_rigid(p, q);
  if (mv.mirrored) {
    // The reflected faces keep their input shape as a mirror image: no face is re-oriented, their
    // distortion and flip tests measure against the mirrored input triangle.
    mirror_faces(C(mv.small).faces);
    L.saved_mirrored = true;
  }
  for (int f : C(mv.small).faces)
    for (int k = 0; k < 3; ++k) {
      const int w = wedge(f, k);
      if (wstamp_[static_cast<size_t>(w)] == L.epoch) continue;
      save_uv(L, w);
      wmoved_[static_cast<size_t>(w)] = L.epoch;
      uv(w) = m(uv(w));
    }
}

void Engine::weld(Move& mv) {
  Lane& L = *mv.lane;
  // Union the pairs; each group moves to its mean; representative = a wedge of the bigger chart.
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
  for (const auto& [wb, ws] : mv.pairs) {
    const int rb = find(wb), rs = find(ws);
    if (rb != rs) parent[std::max(rb, rs)] = std::min(rb, rs);
  }
  std::unordered_map<int, std::vector<int>> groups;
  for (const auto& [w, par] : parent) {
    (void)par;
    groups[find(w)].push_back(w);
  }
  std::unordered_map<int, int> rep_of;
  std::unordered_map<int, char> is_big;
  for (const auto& pr : mv.pairs) is_big[pr.first] = 1;
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
      mv.dmax = std::max(mv.dmax, (uv(w) - mean).norm());
      save_uv(L, w);
      wmoved_[static_cast<size_t>(w)] = L.epoch;
      uv(w) = mean;
      rep_of[w] = r;
    }
    mv.reps.push_back(r);
    wrep_[static_cast<size_t>(r)] = L.epoch;
  }
  // Repoint corners of both charts at the welded vertices.
  for (const auto& [root, members] : groups) {
    (void)root;
    const int v = at_.wedge_vertex[static_cast<size_t>(members.front())];
    for (int i = vf_off_[static_cast<size_t>(v)]; i < vf_off_[static_cast<size_t>(v) + 1]; ++i) {
      const int f = vf_[static_cast<size_t>(i)];
      const int c = chart(f);
      if (c != mv.big && c != mv.small) continue;
      for (int k = 0; k < 3; ++k) {
        auto it = rep_of.find(wedge(f, k));
        if (it == rep_of.end() || it->second == wedge(f, k)) continue;
        if (fstamp_[static_cast<size_t>(f)] != L.epoch) {
          fstamp_[static_cast<size_t>(f)] = L.epoch;
          L.saved_fw.emplace_back(f, at_.face_wedge[static_cast<size_t>(f)]);
        }
        at_.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)] = it->second;
      }
    }
  }
  if (!mv.self)
    for (int f : C(mv.small).faces) set_chart(f, mv.big);
}

bool Engine::seam_edge_folded(int ei) const {
  const Edge& e = topo_.edges[static_cast<size_t>(ei)];
  double s[2];
  for (int i = 0; i < 2; ++i) {
    const EdgeIncidence& in = topo_.edge_faces[static_cast<size_t>(e.first_incidence + i)];
    const int f = in.face, k = in.local;
    const auto& P = at_.wedge_uv;
    s[i] = orient2d(P[static_cast<size_t>(wedge(f, 0))], P[static_cast<size_t>(wedge(f, 1))],
                    P[static_cast<size_t>(wedge(f, 2))]);
    // Same-sidedness of the opposite corners <=> equal orientation along opposite traversal.
    const bool forward = topo_.face_vertex[static_cast<size_t>(f)][static_cast<size_t>(k)] == e.a;
    if (!forward) s[i] = -s[i];
  }
  // Traversed a->b, face 0's third corner is on side sign(s0); face 1's on side sign(s1).
  return !(s[0] * s[1] < 0);
}

bool Engine::seam_mirrored(int big, int small) {
  // seam_edge_folded compares the signs of the two faces' own UV turns along the edge, which no
  // proper rigid motion changes: evaluated before the alignment it tells whether one is needed.
  // Edges with a face of zero UV area (no turn) do not vote.
  const std::vector<int>& edges = C(big).adj[small];
  size_t nfold = 0, nvote = 0;
  for (int ei : edges) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    bool decisive = true;
    for (int i = 0; i < 2; ++i)
      decisive = decisive && rest_w_[static_cast<size_t>(topo_.edge_faces[static_cast<size_t>(e.first_incidence + i)].face)] > 0;
    if (!decisive) continue;
    ++nvote;
    nfold += seam_edge_folded(ei) ? 1 : 0;
  }
  return 2 * nfold > nvote;
}

void Engine::mirror_faces(const std::vector<int>& faces) {
  for (int f : faces) {
    fmirror_[static_cast<size_t>(f)] ^= 1;
    rest_inv_[static_cast<size_t>(f)].col(1) = -rest_inv_[static_cast<size_t>(f)].col(1);
    if (fthin_[static_cast<size_t>(f)]) {
      Mat2& t = thin_inv_.at(f);
      t.col(1) = -t.col(1);
    }
  }
}

const char* Engine::check_orientation(Move& mv) const {
  // The framework measures a reflected input chart through the mirror only when it turns like the
  // rest of its output chart (core/distortion.h); one that turns against it counts as flipped and
  // with its full mirror-image error. Where the 3D winding is consistent a reflection makes the
  // smaller chart turn like the bigger one, so this always holds; across a seam whose two faces are
  // wound inconsistently in 3D, the fold-free weld is the one that reverses the turn.
  const ChartInfo& B = charts_[static_cast<size_t>(mv.big)];
  const ChartInfo& S = charts_[static_cast<size_t>(mv.small)];
  mv.groups = B.groups;
  for (size_t m = 0; m < 2; ++m)
    for (size_t t = 0; t < 3; ++t)
      mv.groups[mv.mirrored ? 1 - m : m][mv.mirrored ? 2 - t : t] += S.groups[m][t];
  mv.turn = B.turn + (mv.mirrored ? -S.turn : S.turn);
  const std::array<int, 3>& reflected = mv.groups[1];
  if (reflected[0] + reflected[1] + reflected[2] == 0) return nullptr;
  // note: the framework adds the chart's turn in face order, this sum in merge order: a margin keeps
  // their signs equal.
  const double margin = 1e-9 * (B.uv_area + S.uv_area);
  if (reflected[1] > 0 || std::abs(mv.turn) <= margin) return "mirror_orientation";
  return reflected[mv.turn > 0 ? 0 : 2] > 0 ? "mirror_orientation" : nullptr;
}

bool Engine::seam_mostly_folded(const Move& mv) const {
  size_t nfold = 0;
  for (int ei : mv.seam_edges) nfold += seam_edge_folded(ei) ? 1 : 0;
  return 2 * nfold > mv.seam_edges.size();
}

void Engine::free_region(Move& mv) {
  Lane& L = *mv.lane;
  // Dijkstra over UV edge lengths from the welded wedges, radius alpha * dmax.
  const double radius = opt_.alpha * mv.dmax;
  using QE = std::pair<double, int>;
  std::priority_queue<QE, std::vector<QE>, std::greater<QE>> pq;
  auto dist = [&](int w) -> double& {
    if (wvisit_[static_cast<size_t>(w)] != L.epoch) {
      wvisit_[static_cast<size_t>(w)] = L.epoch;
      wdist_[static_cast<size_t>(w)] = std::numeric_limits<double>::infinity();
    }
    return wdist_[static_cast<size_t>(w)];
  };
  for (int r : mv.reps) {
    dist(r) = 0;
    pq.emplace(0.0, r);
  }
  while (!pq.empty() && static_cast<int>(mv.free_w.size()) < opt_.max_free_vertices) {
    // note: plain variables, not a structured binding: the lambdas below capture them (C++17 and
    // Clang 14 do not allow capturing structured bindings).
    const double d = pq.top().first;
    const int w = pq.top().second;
    pq.pop();
    if (wdone_[static_cast<size_t>(w)] == L.epoch || d > dist(w)) continue;
    wdone_[static_cast<size_t>(w)] = L.epoch;
    if (d > radius) break;
    bool pinned = false;
    faces_of_wedge(w, mv.big, [&](int f, int) {
      if (rest_w_[static_cast<size_t>(f)] == 0) pinned = true;
    });
    if (pinned) continue;
    mv.free_w.push_back(w);
    faces_of_wedge(w, mv.big, [&](int f, int k) {
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

bool Engine::full_boundary_fan(int w, int c) const {
  double in = 0;
  bool boundary = false;
  faces_of_wedge(w, c, [&](int f, int k) {
    if (is_boundary(f, k, c) || is_boundary(f, (k + 2) % 3, c)) boundary = true;
    const size_t g = static_cast<size_t>(f);
    in += corner_angle(mesh_.corner_texel(g, k), mesh_.corner_texel(g, (k + 1) % 3), mesh_.corner_texel(g, (k + 2) % 3));
  });
  // note: within 2% of a turn: the local/global steps overshoot a fan's input angles by a few
  // degrees (a fan of 357 input degrees refused at 360.2 on the 20k synthetic factory).
  constexpr double kTwoPi = 6.283185307179586, kMargin = 0.02;
  return boundary && in >= kTwoPi * (1 - kMargin);
}

void Engine::hold_full_fans(Move& mv) {
  // A fan changes when its wedge or one of its ring moves: every over-full boundary fan at a free
  // wedge or next to one is held by keeping its wedge and ring (welded wedges excepted) pinned, so its
  // faces keep the shape earlier merges gave them.
  Lane& L = *mv.lane;
  std::unordered_set<int> seen, held;
  auto ring = [&](int x, auto&& fn) {
    faces_of_wedge(x, mv.big, [&](int f, int k) {
      for (int j = 1; j < 3; ++j) fn(wedge(f, (k + j) % 3));
    });
  };
  auto welded = [&](int x) { return wrep_[static_cast<size_t>(x)] == L.epoch; };
  auto consider = [&](int x) {
    if (!seen.insert(x).second || welded(x) || !full_boundary_fan(x, mv.big)) return;
    held.insert(x);
    ring(x, [&](int u) {
      if (!welded(u)) held.insert(u);
    });
  };
  for (int w : mv.free_w) {
    consider(w);
    ring(w, consider);
  }
  if (held.empty()) return;
  std::vector<int> kept;
  for (int w : mv.free_w)
    if (!held.count(w)) kept.push_back(w);
  mv.free_w = std::move(kept);
}

void Engine::free_fan_rings(Move& mv) {
  // A boundary fan whose input angles add up to more than a turn can only close at fan_targets'
  // angles when the wedges around it may move too: with a small weld displacement the free region
  // is the welded wedges alone and their neighbours are pinned where the input put them.
  constexpr double kTwoPi = 6.283185307179586;
  const double turn = kTwoPi * (1 - opt_.fan_margin);
  std::unordered_set<int> in(mv.free_w.begin(), mv.free_w.end());
  const size_t n = mv.free_w.size();
  for (size_t i = 0; i < n; ++i) {
    const int w = mv.free_w[i];
    double rest = 0;
    bool boundary = false, zero = false;
    faces_of_wedge(w, mv.big, [&](int g, int k) {
      if (rest_w_[static_cast<size_t>(g)] == 0) zero = true;
      if (is_boundary(g, k, mv.big) || is_boundary(g, (k + 2) % 3, mv.big)) boundary = true;
      const Vec2 P = mesh_.corner_texel(g, k), A = mesh_.corner_texel(g, (k + 1) % 3) - P,
                 B = mesh_.corner_texel(g, (k + 2) % 3) - P;
      rest += std::abs(std::atan2(A.x() * B.y() - A.y() * B.x(), A.dot(B)));
    });
    if (!boundary || zero || rest <= turn) continue;
    faces_of_wedge(w, mv.big, [&](int g, int k) {
      for (int j = 1; j < 3; ++j) {
        const int u = wedge(g, (k + j) % 3);
        if (static_cast<int>(mv.free_w.size()) >= opt_.max_free_vertices || in.count(u)) continue;
        bool pinned = false;
        faces_of_wedge(u, mv.big, [&](int h, int) { pinned = pinned || rest_w_[static_cast<size_t>(h)] == 0; });
        if (pinned) continue;
        in.insert(u);
        mv.free_w.push_back(u);
      }
    });
  }
}

void Engine::solve(Move& mv) {
  Lane& L = *mv.lane;
  LocalProblem lp;
  // Local index of each wedge of the problem: wlocal_[w], valid when wlocal_stamp_[w] == L.epoch.
  auto add_local = [&](int w) {
    wlocal_stamp_[static_cast<size_t>(w)] = L.epoch;
    wlocal_[static_cast<size_t>(w)] = static_cast<int>(lp.x.size());
    lp.x.push_back(uv(w));
  };
  auto local = [&](int w) { return wlocal_[static_cast<size_t>(w)]; };
  for (int w : mv.free_w) add_local(w);
  lp.num_free = static_cast<int>(lp.x.size());
  for (int w : mv.free_w)
    faces_of_wedge(w, mv.big, [&](int f, int) {
      if (fchanged_[static_cast<size_t>(f)] == L.epoch) return;
      fchanged_[static_cast<size_t>(f)] = L.epoch;
      mv.prob_faces.push_back(f);
    });
  for (int f : mv.prob_faces)
    for (int k = 0; k < 3; ++k)
      if (wlocal_stamp_[static_cast<size_t>(wedge(f, k))] != L.epoch) add_local(wedge(f, k));
  if (lp.num_free > 0 && static_cast<int>(lp.x.size()) == lp.num_free) {
    // The whole chart is free: pin the farthest free wedge so rigid motions are fixed.
    --lp.num_free;
  }
  std::unordered_map<int, Mat2> target;
  if (opt_.fan_targets) fan_targets(mv, target);
  for (int f : mv.prob_faces) {
    lp.tri.push_back({local(wedge(f, 0)), local(wedge(f, 1)), local(wedge(f, 2))});
    auto it = target.find(f);
    lp.rest_inv.push_back(it != target.end()           ? it->second
                          : fthin_[static_cast<size_t>(f)] ? thin_inv_.at(f)
                                                           : rest_inv_[static_cast<size_t>(f)]);
    lp.weight.push_back(rest_w_[static_cast<size_t>(f)]);
  }
  if (mv.fill_holes) {
    const auto local_of = [&](int w) {
      if (wlocal_stamp_[static_cast<size_t>(w)] != L.epoch) add_local(w);
      return local(w);
    };
    const size_t filled = add_hole_faces(mv, lp, local_of);
    L.rep.holes_filled += filled;
    if (filled == 0) {
      // note: no hole could be triangulated (a loop crossing itself): the solve would be the refused
      // one again, so the move is refused as before without solving (evaluate_welded).
      mv.fill_failed = true;
      return;
    }
  }
  lp.repair_usable = !repair_spent(L);
  L.free_total += lp.num_free;
  ++L.free_count;
  const auto t0 = Clock::now();
  const SolveResult res = solver_.solve(lp);
  mv.solved = res.ok;
  mv.repaired = res.repaired;
  if (res.repaired) {
    ++L.rep.repairs_tried;
    if (res.ok) ++L.rep.repairs_untangled;
  }
  L.rep.optimisation_seconds += seconds_since(t0);
  for (int i = 0; i < lp.num_free; ++i) {
    const int w = mv.free_w[static_cast<size_t>(i)];
    save_uv(L, w);
    wmoved_[static_cast<size_t>(w)] = L.epoch;
    uv(w) = lp.x[static_cast<size_t>(i)];
  }
  // Faces whose shape changed (beyond the rigid motion): those around moved seam/free wedges.
  mv.changed = mv.prob_faces;
  for (int r : mv.reps)
    faces_of_wedge(r, mv.big, [&](int f, int) {
      if (fchanged_[static_cast<size_t>(f)] == L.epoch) return;
      fchanged_[static_cast<size_t>(f)] = L.epoch;
      mv.changed.push_back(f);
    });
}

void Engine::fan_targets(const Move& mv, std::unordered_map<int, Mat2>& target) {
  Lane& L = *mv.lane;
  // A boundary wedge of the merged chart whose faces' input UV angles add up to more than a full
  // turn cannot keep them: the solver, pulled towards the input shapes, would open the fan past
  // 2 pi (fan_overlap). Its problem faces get target shapes whose angles there are scaled down so
  // that, with the fixed angles of its faces outside the problem, the fan closes at kFanTurn; the
  // other two angles of each such face grow in proportion, its area stays. Acceptance still measures
  // every face against its input UV triangle, so the compression is paid from the same budgets.
  constexpr double kTwoPi = 6.283185307179586, kPi = 3.141592653589793;
  const double kFanTurn = kTwoPi * (1 - opt_.fan_margin);
  std::unordered_map<int, std::array<double, 3>> scale;
  std::vector<int> seen;
  for (int f : mv.prob_faces)
    for (int k = 0; k < 3; ++k) {
      const int w = wedge(f, k);
      if (wfan_[static_cast<size_t>(w)] == -L.epoch) continue;
      wfan_[static_cast<size_t>(w)] = -L.epoch;
      double rest = 0, fixed = 0;
      bool boundary = false, zero = false;
      faces_of_wedge(w, mv.big, [&](int g, int kk) {
        if (rest_w_[static_cast<size_t>(g)] == 0) zero = true;
        if (is_boundary(g, kk, mv.big) || is_boundary(g, (kk + 2) % 3, mv.big)) boundary = true;
        if (fchanged_[static_cast<size_t>(g)] == L.epoch) {
          rest += corner_angle(mesh_.corner_texel(g, kk), mesh_.corner_texel(g, (kk + 1) % 3), mesh_.corner_texel(g, (kk + 2) % 3));
        } else {
          fixed += corner_angle(uv(wedge(g, kk)), uv(wedge(g, (kk + 1) % 3)), uv(wedge(g, (kk + 2) % 3)));
        }
      });
      const double room = kFanTurn - fixed;
      if (!boundary || zero || rest <= room || room <= 0) continue;
      const double s = room / rest;
      faces_of_wedge(w, mv.big, [&](int g, int kk) {
        if (fchanged_[static_cast<size_t>(g)] != L.epoch) return;
        auto it = scale.emplace(g, std::array<double, 3>{1, 1, 1}).first;
        it->second[static_cast<size_t>(kk)] *= s;
      });
    }
  for (const auto& [f, sc] : scale) {
    std::array<double, 3> ang;
    for (int k = 0; k < 3; ++k)
      ang[static_cast<size_t>(k)] = corner_angle(mesh_.corner_texel(f, k), mesh_.corner_texel(f, (k + 1) % 3), mesh_.corner_texel(f, (k + 2) % 3));
    // Scaled corners take their scaled angles, the others share what is left of pi in proportion.
    double fixed_sum = 0, free_sum = 0;
    for (size_t k = 0; k < 3; ++k) (sc[k] < 1 ? fixed_sum : free_sum) += sc[k] < 1 ? sc[k] * ang[k] : ang[k];
    if (free_sum <= 0 || fixed_sum >= kPi) continue;
    std::array<double, 3> a;
    for (size_t k = 0; k < 3; ++k) a[k] = sc[k] < 1 ? sc[k] * ang[k] : ang[k] * (kPi - fixed_sum) / free_sum;
    // The triangle with these angles and the input triangle's area, turning like its rest shape.
    const double l1 = std::sin(a[1]), l2 = std::sin(a[2]);  // sides opposite corners 1 and 2
    Vec2 p1(l2, 0), p2(l1 * std::cos(a[0]), l1 * std::sin(a[0]));
    const double area = 0.5 * std::abs(p1.x() * p2.y() - p1.y() * p2.x());
    if (!(area > 0)) continue;
    const double r = std::sqrt(rest_w_[static_cast<size_t>(f)] / area);
    p1 *= r;
    p2 *= r;
    if (rest_inv_[static_cast<size_t>(f)].determinant() < 0) {
      p1.y() = -p1.y();
      p2.y() = -p2.y();
    }
    Mat2 Dm;
    Dm.col(0) = p1;
    Dm.col(1) = p2;
    target[f] = Dm.inverse();
  }
  if (!target.empty()) ++L.rep.fan_target_moves;
}

const char* Engine::check(Move& mv) {
  if (!mv.solved) return "flip";
  if (const char* why = check_shapes(mv)) return why;
  if (const char* why = check_folds(mv)) return why;
  // note: with partial welds or hole filling the fans come before the distortion, so that whether a
  // move is tried again never depends on the budget, which a second-pass speculation's lane does not
  // know (engine_speculate.cpp): the same tries on every thread count. The order changes only which
  // refusal is reported, never whether a move is accepted.
  const bool fans_first = opt_.partial_weld_tries > 0 || opt_.fill_holes || opt_.hold_full_fans;
  if (fans_first)
    if (const char* why = check_fans(mv)) return why;
  if (const char* why = check_distortion(mv)) return why;
  if (!fans_first)
    if (const char* why = check_fans(mv)) return why;
  if (const char* why = check_boundary(mv)) return why;
  return check_triangles(mv);
}

/// Signed UV area (texels^2) of face f at its current wedge positions.
double Engine::signed_uv_area(int f) {
  const Vec2 a = uv(wedge(f, 1)) - uv(wedge(f, 0)), b = uv(wedge(f, 2)) - uv(wedge(f, 0));
  return 0.5 * (a.x() * b.y() - a.y() * b.x());
}

/// +1 / -1: the orientation (sign of the signed UV area) of chart c's faces that have input UV
/// area (their Jacobians keep it, so one face tells); 0 when it has none.
int Engine::chart_orientation(int c) {
  for (int f : C(c).faces)
    if (rest_w_[static_cast<size_t>(f)] > 0) return signed_uv_area(f) > 0 ? 1 : -1;
  return 0;
}

const char* Engine::check_shapes(const Move& mv) {
  // Flips first (any flipped face makes the reason "flip"), then near-collapsed faces. A face of
  // zero input UV area has no rest shape (no Jacobian, no weight), but it may not turn over
  // either: once its signed UV area is beyond the framework's overlap threshold (1e-6 texels^2,
  // core/uv_overlap.h) it must have the merged chart's orientation, else it would overlap its
  // neighbours (seen on a real 3D Tiles producer whose atlas has many zero-area faces).
  constexpr double kZeroFaceFlipArea = 1e-6;
  bool collapsed = false;
  int orientation = 2;  // not yet computed
  for (int f : mv.changed) {
    if (rest_w_[static_cast<size_t>(f)] == 0) {
      if (topo_.face_degenerate[static_cast<size_t>(f)]) continue;
      if (orientation == 2) orientation = chart_orientation(mv.big);
      if (orientation * signed_uv_area(f) < -kZeroFaceFlipArea) return "flip";
      continue;
    }
    const Mat2 J = jacobian(f);
    if (J.determinant() <= 0) return "flip";
    // A face closed below what a float32 file can orient once its chart is turned is as good as
    // flipped: a thin face below its floor (open_thin_faces), any other below half kThinAltitude.
    const bool thin = fthin_[static_cast<size_t>(f)];
    if (oriented_altitude(f) < (thin ? thin_alt_.at(f) : 0.5 * kThinAltitude)) return "flip";
    if (opt_.min_singular_value > 0 && !collapsed)
      collapsed = signed_singular_values_2x2(J)[1] < opt_.min_singular_value;
  }
  return collapsed ? "collapse" : nullptr;
}

const char* Engine::check_folds(const Move& mv) const {
  for (int ei : mv.seam_edges)
    if (seam_edge_folded(ei)) return "fold";
  return nullptr;
}

const char* Engine::check_distortion(Move& mv) {
  Lane& L = *mv.lane;
  mv.new_err.assign(mv.changed.size(), 0);
  double delta = 0, lsum = 0, lw = 0;
  for (size_t i = 0; i < mv.changed.size(); ++i) {
    const int f = mv.changed[i];
    mv.new_err[i] = weighted_err(f);
    delta += mv.new_err[i] - err_w_[static_cast<size_t>(f)];
    lsum += mv.new_err[i];
    lw += rest_w_[static_cast<size_t>(f)];
  }
  if (lw > 0 && lsum / lw > opt_.local_bound) return "local_distortion";
  // A repaired solve is a costly weld (flip-free only after untangling): in a region's lane of the
  // first pass it must be cheap; globally it may only spend the first part of the budget (budget_refusal).
  if (mv.repaired && L.region >= 0 && lw > 0 && lsum / lw > opt_.repaired_local_bound) return "local_distortion";
  if (const char* why = price_refusal(mv, delta)) return why;
  mv.new_sum = L.err_sum + delta;
  mv.budget_checked = true;
  return budget_refusal(L, mv.new_sum, mv.repaired);
}

const char* Engine::price_refusal(const Move& mv, double delta) const {
  if (!price_on_ || mv.self || weight_sum_ <= 0 || seam_in_3d_ <= 0 || opt_.global_bound <= 0) return nullptr;
  // note: where the budget binds, half of it went to merges that welded 7% of the seam (hard synthetic
  // seed 11 b0002, best.json); a cap on the budget spent per seam welded keeps it for longer seams.
  const double budget_share = delta / (opt_.global_bound * weight_sum_);
  const double seam_share = edges_length_3d(mv.seam_edges) / seam_in_3d_;
  return budget_share > opt_.max_seam_price * seam_share ? "price" : nullptr;
}

void Engine::load_before(const Lane& L, Before& b) const {
  if (b.lane == &L) return;
  b.lane = &L;
  // note: each entry is the first save of the move, i.e. the state before it.
  for (const auto& [w, p] : L.saved_uv) b.uv.emplace(w, p);
  for (const auto& [f, fw] : L.saved_fw) b.fw.emplace(f, fw);
}

Tri2 Engine::tri2_before(const Before& b, int f) const {
  Tri2 t;
  t.face = f;
  auto fi = b.fw.find(f);
  for (size_t k = 0; k < 3; ++k) {
    t.w[k] = fi != b.fw.end() ? fi->second[k] : wedge(f, static_cast<int>(k));
    auto ui = b.uv.find(t.w[k]);
    t.p[k] = ui != b.uv.end() ? ui->second : at_.wedge_uv[static_cast<size_t>(t.w[k])];
  }
  return t;
}

bool Engine::overlap_is_new(const Move& mv, Before& b, const Tri2& x, const Tri2& y) const {
  if (x.face < 0 || y.face < 0 || !same_chart_before(mv, x.face, y.face)) return true;
  load_before(*mv.lane, b);
  const Tri2 xb = tri2_before(b, x.face), yb = tri2_before(b, y.face);
  if (!triangles_overlap(xb, yb)) return true;
  // An overlap of the input's (a sliver over its neighbour, often under 1e-9 texel^2) that the move
  // grows past what the pipeline counts is the move's doing too.
  return crosses_counted_overlap(xb, yb, x, y);
}

const char* Engine::check_fans(Move& mv) {
  Lane& L = *mv.lane;
  Before before;
  // The triangles around a wedge must not wrap over each other. Boundary segments that share a
  // wedge are never tested for crossing, so a boundary wedge whose incident angles add up to 2 pi
  // or more (the merge nearly closed a fan whose input angles exceed 2 pi) overlaps without any
  // crossing; an interior wedge must have exactly 2 pi (more: a pinch of two fans, or a multiple cover).
  for (int f : mv.changed)
    for (int k = 0; k < 3; ++k) {
      const int w = wedge(f, k);
      if (wfan_[static_cast<size_t>(w)] == L.epoch) continue;
      wfan_[static_cast<size_t>(w)] = L.epoch;
      if (!fan_overlaps(w, mv.big)) continue;
      // A fan that overlapped before the move (an input chart's own overlap: noisy photogrammetry)
      // is not the move's doing when the move only kept or narrowed it: an unwelded wedge whose faces
      // turn no further around it than before.
      if (wrep_[static_cast<size_t>(w)] != L.epoch) {
        load_before(L, before);
        double now = 0, then = 0;
        faces_of_wedge(w, mv.big, [&](int f, int k) {
          const Tri2 a = tri2(f), b = tri2_before(before, f);
          const size_t i = static_cast<size_t>(k), j = static_cast<size_t>((k + 1) % 3), l = static_cast<size_t>((k + 2) % 3);
          now += std::abs(std::atan2(orient2d(a.p[i], a.p[j], a.p[l]), (a.p[j] - a.p[i]).dot(a.p[l] - a.p[i])));
          then += std::abs(std::atan2(orient2d(b.p[i], b.p[j], b.p[l]), (b.p[j] - b.p[i]).dot(b.p[l] - b.p[i])));
        });
        constexpr double kTwoPi = 6.283185307179586;
        if (then >= kTwoPi * (1 - 1e-9) && now <= then + 1e-9) continue;
      }
      mv.fan_wedge = w;
      mv.fan_welded = wrep_[static_cast<size_t>(w)] == L.epoch;
      return "fan_overlap";
    }
  return nullptr;
}

const char* Engine::check_boundary(Move& mv) {
  // Self-overlap of the merged chart: its moved boundary segments against its other boundary
  // segments. Only edges with a welded (representative) wedge can stop being boundary edges; only
  // edges of the smaller chart and of the changed faces can have moved. The other segments come from
  // the bigger chart's segment grid, queried with the moved segments' boxes, so the test costs
  // O(moved segments + segments near them), not O(boundary).
  collect_moved_edges(mv);
  std::vector<Segment> all, moved;
  moved.reserve(mv.moved_ids.size());
  for (int e : mv.moved_ids) moved.push_back(edge_segment(e));
  gather_unmoved_segments(mv, moved, all);
  // Only a crossing the move added counts (as for triangles in check_triangles): two boundary
  // segments of faces that were in one chart and crossed before the move are an input overlap.
  Before before;
  auto is_new = [&](const Segment& x, const Segment& y) { return crossing_is_new(mv, before, x, y); };
  return any_crossing(moved, all, is_new) ? "overlap" : nullptr;
}

void Engine::collect_moved_edges(Move& mv) {
  const ChartInfo& Sm = C(mv.small);
  if (!mv.self)
    for (const auto& fk : Sm.boundary)
      if (ebnd_[3 * static_cast<size_t>(fk.first) + static_cast<size_t>(fk.second)]) classify_edges(mv, fk.first);
  for (int f : mv.changed) classify_edges(mv, f);
  for (int r : mv.reps) faces_of_wedge(r, mv.big, [&](int f, int) { classify_edges(mv, f); });
}

void Engine::classify_edges(Move& mv, int f) {
  const Lane& L = *mv.lane;
  for (int k = 0; k < 3; ++k) {
    const int e = 3 * f + k;
    if (!ebnd_[static_cast<size_t>(e)] || emoved_[static_cast<size_t>(e)] == L.epoch ||
        edead_[static_cast<size_t>(e)] == L.epoch)
      continue;
    const int w0 = wedge(f, k), w1 = wedge(f, (k + 1) % 3);
    if ((wrep_[static_cast<size_t>(w0)] == L.epoch || wrep_[static_cast<size_t>(w1)] == L.epoch) &&
        !is_boundary(f, k, mv.big)) {
      edead_[static_cast<size_t>(e)] = L.epoch;
      mv.dead.push_back(e);
      continue;
    }
    if (wmoved_[static_cast<size_t>(w0)] == L.epoch || wmoved_[static_cast<size_t>(w1)] == L.epoch) {
      emoved_[static_cast<size_t>(e)] = L.epoch;
      mv.moved_ids.push_back(e);
    }
  }
}

Segment Engine::edge_segment(int e) {
  Segment sg;
  sg.w0 = wedge(e / 3, e % 3);
  sg.w1 = wedge(e / 3, (e % 3 + 1) % 3);
  sg.edge = e;
  sg.a = uv(sg.w0);
  sg.b = uv(sg.w1);
  return sg;
}

void Engine::gather_unmoved_segments(const Move& mv, const std::vector<Segment>& moved,
                                     std::vector<Segment>& all) {
  Lane& L = *mv.lane;
  const ChartInfo& Bg = C(mv.big);
  const ChartInfo& Sm = C(mv.small);
  ++L.seen_stamp;
  auto visit = [&](int e) {
    if (eseen_[static_cast<size_t>(e)] == L.seen_stamp) return;
    eseen_[static_cast<size_t>(e)] = L.seen_stamp;
    if (!ebnd_[static_cast<size_t>(e)] || emoved_[static_cast<size_t>(e)] == L.epoch ||
        edead_[static_cast<size_t>(e)] == L.epoch)
      return;
    all.push_back(edge_segment(e));
  };
  // The smaller chart's unmoved segments (none after a rigid alignment, kept for safety).
  if (!mv.self)
    for (const auto& [f, k] : Sm.boundary) visit(3 * f + k);
  if (moved.empty()) return;
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

bool Engine::crossing_is_new(const Move& mv, Before& b, const Segment& x, const Segment& y) const {
  if (x.edge < 0 || y.edge < 0 || !same_chart_before(mv, x.edge / 3, y.edge / 3)) return true;
  load_before(*mv.lane, b);
  const Tri2 tx = tri2_before(b, x.edge / 3), ty = tri2_before(b, y.edge / 3);
  const size_t kx = static_cast<size_t>(x.edge % 3), ky = static_cast<size_t>(y.edge % 3);
  return !segments_cross(tx.p[kx], tx.p[(kx + 1) % 3], ty.p[ky], ty.p[(ky + 1) % 3]);
}

const char* Engine::check_triangles(const Move& mv) {
  // Every moved or changed triangle against every other triangle of the merged chart. The boundary
  // and fan tests miss overlaps that neither cross a boundary nor wrap a fan seen by this merge:
  // another sheet of a multi-sheeted input chart, or a chart whose fan the earlier merges closed
  // around a wedge with input angles far above 2 pi (t078_L15: a 1-face chart welded onto a 4 pi
  // double cover). Pairs of unchanged triangles keep their relative positions (the bigger chart's
  // stay put, the smaller chart's move rigidly together), so testing every pair with a moved
  // triangle means no merge adds an overlapping pair.
  // note: conservative: an input overlap among the moved triangles also rejects the merge.
  std::vector<Tri2> mt, rest;
  Vec2 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()), hi = -lo;
  const size_t rigid = collect_moved_triangles(mv, mt, lo, hi);
  gather_triangles_near(mv, mt, lo, hi, rest);
  // Only a pair the move added counts: an input chart's own overlapping triangles (multi-sheeted
  // photogrammetry charts) that keep overlapping do not refuse every move touching them.
  Before before;
  auto is_new = [&](const Tri2& x, const Tri2& y) { return overlap_is_new(mv, before, x, y); };
  return any_triangle_overlap(mt, rest, rigid, is_new) ? "overlap" : nullptr;
}

size_t Engine::collect_moved_triangles(const Move& mv, std::vector<Tri2>& mt, Vec2& lo, Vec2& hi) {
  const Lane& L = *mv.lane;
  auto grow = [&](const Tri2& t) {
    for (const Vec2& q : t.p) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  };
  // The smaller chart's unchanged faces first: they moved rigidly together, so when the smaller chart
  // has no overlapping pair (self_overlap false: none in its input charts, and every accepted merge
  // tested each pair with a moved triangle) no pair of them is tested again.
  // (A closed cut moves nothing rigidly: the chart's unchanged faces are the bigger chart's below.)
  const ChartInfo& Sm = C(mv.small);
  if (!mv.self)
    for (int f : Sm.faces)
      if (rest_w_[static_cast<size_t>(f)] > 0 && fchanged_[static_cast<size_t>(f)] != L.epoch) {
        mt.push_back(tri2(f));
        grow(mt.back());
      }
  // (Pairs of them overlap as they did before the move: never new, so never tested.)
  const size_t rigid = mt.size();
  // The changed faces of both charts (every face with fchanged_ == L.epoch is in `changed`).
  for (int f : mv.changed)
    if (rest_w_[static_cast<size_t>(f)] > 0) {
      mt.push_back(tri2(f));
      grow(mt.back());
    }
  return rigid;
}

void Engine::gather_triangles_near(const Move& mv, const std::vector<Tri2>& mt, const Vec2& lo, const Vec2& hi,
                                   std::vector<Tri2>& rest) {
  Lane& L = *mv.lane;
  const ChartInfo& Bg = C(mv.big);
  // Only the bigger chart's unchanged triangles whose box meets the moved triangles' box can overlap
  // them. Candidates come from its triangle grid, queried with each moved triangle's box widened by
  // more than triangles_overlap's touching tolerance (1e-7 x the longest edge of the pair; grid
  // triangles span at most kMaxTriCells cells); when the query would visit more cells than the chart
  // has faces, scan the faces instead.
  auto keep = [&](int f) {
    if (fchanged_[static_cast<size_t>(f)] == L.epoch || rest_w_[static_cast<size_t>(f)] == 0) return;
    const Vec2& a = uv(wedge(f, 0));
    const Vec2& b = uv(wedge(f, 1));
    const Vec2& c = uv(wedge(f, 2));
    if (std::max({a.x(), b.x(), c.x()}) < lo.x() || std::min({a.x(), b.x(), c.x()}) > hi.x() ||
        std::max({a.y(), b.y(), c.y()}) < lo.y() || std::min({a.y(), b.y(), c.y()}) > hi.y())
      return;
    rest.push_back(tri2(f));
  };
  double ncells = 0;
  const std::vector<std::array<int, 4>> qr = triangle_query_cells(mt, ncells);
  if (ncells > static_cast<double>(Bg.faces.size())) {
    for (int f : Bg.faces) keep(f);
  } else {
    ++L.seen_stamp;
    auto visit = [&](int f) {
      if (fseen_[static_cast<size_t>(f)] == L.seen_stamp) return;
      fseen_[static_cast<size_t>(f)] = L.seen_stamp;
      keep(f);
    };
    Bg.tris.query(qr, visit);
  }
}

std::vector<std::array<int, 4>> Engine::triangle_query_cells(const std::vector<Tri2>& mt, double& ncells) const {
  std::vector<std::array<int, 4>> qr;
  qr.reserve(mt.size());
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
  return qr;
}

void Engine::commit(Move& mv) {
  Lane& L = *mv.lane;
  if (mv.mirrored) ++L.rep.accepted_mirrored;
  if (mv.repaired) ++L.rep.repairs_accepted;
  if (mv.open_ends > 0) ++L.rep.partial_welds_accepted;
  if (mv.self) {
    ++L.rep.cuts_closed;
    L.rep.cut_edges_closed += mv.seam_edges.size();
  }
  for (size_t i = 0; i < mv.changed.size(); ++i) err_w_[static_cast<size_t>(mv.changed[i])] = mv.new_err[i];
  L.err_sum = mv.new_sum;
  C(mv.big).turn = mv.turn;
  C(mv.big).groups = mv.groups;
  commit_grids(mv);
  commit_boundary(mv);
  commit_chart(mv);
}

void Engine::commit_grids(const Move& mv) {
  ChartInfo& Sm = C(mv.small);
  for (int f : mv.changed)
    if (fowner_[static_cast<size_t>(f)] == mv.big) grid_remove(f);
  if (!mv.self) {
    for (int f : Sm.faces) fowner_[static_cast<size_t>(f)] = -1;
    Sm.tris.clear();
    for (int f : Sm.faces)
      if (rest_w_[static_cast<size_t>(f)] > 0) grid_insert(mv.big, f);
  }
  for (int f : mv.changed)
    if (rest_w_[static_cast<size_t>(f)] > 0 && fowner_[static_cast<size_t>(f)] != mv.big) grid_insert(mv.big, f);
}

void Engine::commit_boundary(const Move& mv) {
  // The weld's interior edges die; moved segments are re-gridded; the smaller chart's live edges are
  // appended in their order.
  ChartInfo& Bg = C(mv.big);
  ChartInfo& Sm = C(mv.small);
  for (int e : mv.dead) {
    if (eowner_[static_cast<size_t>(e)] == mv.big) ++Bg.boundary_dead;  // a tombstone in Bg.boundary
    ebnd_[static_cast<size_t>(e)] = 0;
    seg_remove(e);
  }
  for (int e : mv.moved_ids) {
    seg_remove(e);
    seg_insert(mv.big, e);
  }
  if (mv.self) {
    compact_boundary(Bg);
    if (opt_.priority == Priority::MMethod) {
      Bg.border = 0;
      for (const auto& [f, k] : Bg.boundary)
        if (ebnd_[3 * static_cast<size_t>(f) + static_cast<size_t>(k)]) Bg.border += edge_uv_len(f, k);
    }
    return;
  }
  for (const auto& [f, k] : Sm.boundary) {
    const int e = 3 * f + k;
    if (!ebnd_[static_cast<size_t>(e)]) continue;
    if (eowner_[static_cast<size_t>(e)] != mv.big) {
      seg_remove(e);
      seg_insert(mv.big, e);
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
}

void Engine::commit_chart(const Move& mv) {
  ChartInfo& Bg = C(mv.big);
  if (mv.self) {  // a closed cut: the same faces, pages and neighbours
    ++Bg.version;
    return;
  }
  ChartInfo& Sm = C(mv.small);
  Bg.faces.insert(Bg.faces.end(), Sm.faces.begin(), Sm.faces.end());
  Sm.faces.clear();
  Sm.faces.shrink_to_fit();
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
    at_.chart_page[static_cast<size_t>(mv.big)] = Bg.page;
  }
  Sm.alive = false;
  ++Sm.version;
  ++Bg.version;
  Bg.adj.erase(mv.small);
  for (auto& [c, edges] : Sm.adj) {
    if (c == mv.big) continue;
    auto& to = Bg.adj[c];
    to.insert(to.end(), edges.begin(), edges.end());
    if (!across_ && C(c).region != Bg.region) {
      // note: a chart of another region (or of none) belongs to another lane, which may run on another
      // thread: its adjacency keeps naming the absorbed chart until rebuild_adjacency after the pass.
      mv.lane->stale_adjacency = true;
      continue;
    }
    auto& back = C(c).adj;
    auto& tb = back[mv.big];
    tb.insert(tb.end(), edges.begin(), edges.end());
    back.erase(mv.small);
  }
  Sm.adj.clear();
  refresh_planarity(mv.big);
}

void Engine::rollback(Lane& L) {
  for (auto it = L.saved_uv.rbegin(); it != L.saved_uv.rend(); ++it) uv(it->first) = it->second;
  for (auto it = L.saved_fw.rbegin(); it != L.saved_fw.rend(); ++it)
    at_.face_wedge[static_cast<size_t>(it->first)] = it->second;
  for (int f : C(L.saved_small).faces) set_chart(f, L.saved_small);
  if (L.saved_mirrored) mirror_faces(C(L.saved_small).faces);
  L.saved_mirrored = false;
}

}  // namespace texdefrag::merge::detail
