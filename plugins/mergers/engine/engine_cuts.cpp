// Closing cuts inside one chart (docs/mergers.md, "Closing cuts"): a self-seam edge has both faces
// in the same chart but two UV copies. Welding the copies is a move like a merge without the rigid
// alignment (both sides already lie in one chart's frame): weld at the means, free region, solve,
// the same acceptance checks. It changes the chart's topology, so a cut whose closing would leave
// the chart something other than what it was (a disk stays a disk; a cylinder or a closed surface
// cannot be flattened) is refused as `topology`.
#include "engine_internal.h"

#include <set>

namespace texdefrag::merge::detail {

namespace {
long long wedge_key(int a, int b) {
  return static_cast<long long>(std::min(a, b)) << 32 | static_cast<long long>(std::max(a, b));
}
}  // namespace

std::vector<std::vector<int>> Engine::cut_chains(int c) const {
  const ChartInfo& ch = charts_[static_cast<size_t>(c)];
  // Self-seam edges, and the vertices where the chart's other border edges end.
  std::set<int> cut;
  std::set<int> border_vertex;
  for (const auto& [f, k] : ch.boundary) {
    if (!ebnd_[3 * static_cast<size_t>(f) + static_cast<size_t>(k)]) continue;
    const int ei = topo_.face_edge[static_cast<size_t>(f)][static_cast<size_t>(k)];
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    bool self = false;
    if (e.num_faces == 2 && e.a != e.b) {
      const int g0 = topo_.edge_faces[static_cast<size_t>(e.first_incidence)].face;
      const int g1 = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)].face;
      self = chart(g0) == c && chart(g1) == c && g0 != g1 && !topo_.face_degenerate[static_cast<size_t>(g0)] &&
             !topo_.face_degenerate[static_cast<size_t>(g1)];
    }
    if (self) {
      cut.insert(ei);
    } else {
      border_vertex.insert(e.a);
      border_vertex.insert(e.b);
    }
  }
  std::map<int, std::vector<int>> at;  // vertex -> cut edges
  for (int ei : cut) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    at[e.a].push_back(ei);
    at[e.b].push_back(ei);
  }
  auto through = [&](int v) { return at[v].size() == 2 && !border_vertex.count(v); };
  std::set<int> used;
  std::vector<std::vector<int>> chains;
  auto walk = [&](int v, int ei) {
    std::vector<int> chain;
    while (!used.count(ei)) {
      used.insert(ei);
      chain.push_back(ei);
      const Edge& e = topo_.edges[static_cast<size_t>(ei)];
      v = e.a == v ? e.b : e.a;
      if (!through(v)) break;
      ei = at[v][0] == ei ? at[v][1] : at[v][0];
    }
    return chain;
  };
  // Open chains start at their ends (in vertex order, so the result does not depend on hashing);
  // what is left are closed loops of through vertices.
  for (const auto& [v, edges] : at)
    if (!through(v))
      for (int ei : edges)
        if (!used.count(ei)) chains.push_back(walk(v, ei));
  for (int ei : cut)
    if (!used.count(ei)) chains.push_back(walk(topo_.edges[static_cast<size_t>(ei)].a, ei));
  return chains;
}

Move Engine::begin_close(int c, const std::vector<int>& edges, Lane& L) {
  ++L.epoch;
  ++L.rep.cuts_attempted;
  L.saved_uv.clear();
  L.saved_fw.clear();
  Move mv;
  mv.lane = &L;
  mv.big = mv.small = c;
  mv.self = true;
  L.saved_small = c;
  L.saved_mirrored = false;
  for (int ei : edges) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    const EdgeIncidence& x = topo_.edge_faces[static_cast<size_t>(e.first_incidence)];
    const EdgeIncidence& y = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
    for (int v : {e.a, e.b}) mv.pairs.emplace_back(wedge(x.face, corner_of(x.face, v)), wedge(y.face, corner_of(y.face, v)));
  }
  std::sort(mv.pairs.begin(), mv.pairs.end());
  mv.pairs.erase(std::unique(mv.pairs.begin(), mv.pairs.end()), mv.pairs.end());
  mv.seam_edges = edges;
  mv.turn = C(c).turn;
  mv.groups = C(c).groups;
  return mv;
}

Engine::CutTopology Engine::chart_topology(int c) const {
  const ChartInfo& ch = charts_[static_cast<size_t>(c)];
  std::unordered_map<long long, int> edge_faces;
  std::unordered_map<int, int> wedge_index;
  for (int f : ch.faces)
    for (int k = 0; k < 3; ++k) {
      const int w0 = wedge(f, k), w1 = wedge(f, (k + 1) % 3);
      wedge_index.emplace(w0, static_cast<int>(wedge_index.size()));
      if (w0 != w1) ++edge_faces[wedge_key(w0, w1)];
    }
  CutTopology t;
  t.chi = static_cast<long long>(wedge_index.size()) - static_cast<long long>(edge_faces.size()) +
          static_cast<long long>(ch.faces.size());
  // Boundary loops: components of the boundary edges over their wedges.
  std::vector<int> parent(wedge_index.size()), bdeg(wedge_index.size(), 0);
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
  auto find = [&](int x) {
    while (parent[static_cast<size_t>(x)] != x) x = parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    return x;
  };
  for (const auto& [key, n] : edge_faces) {
    if (n > 2) ++t.nonmanifold;
    if (n != 1) continue;
    const int a = wedge_index[static_cast<int>(key >> 32)], b = wedge_index[static_cast<int>(key & 0xffffffffLL)];
    ++bdeg[static_cast<size_t>(a)];
    ++bdeg[static_cast<size_t>(b)];
    parent[static_cast<size_t>(find(a))] = find(b);
  }
  for (size_t i = 0; i < parent.size(); ++i) {
    if (bdeg[i] == 0) continue;
    if (find(static_cast<int>(i)) == static_cast<int>(i)) ++t.loops;
    if (bdeg[i] > 2) ++t.pinched;
  }
  return t;
}

bool Engine::try_close(int c, const std::vector<int>& edges, std::string& reason, Lane& L) {
  const CutTopology before = chart_topology(c);
  Move mv = begin_close(c, edges, L);
  weld(mv);
  if (!(chart_topology(c) == before)) {
    reason = "topology";
    rollback(L);
    return false;
  }
  return settle_welded(mv, reason, L);
}

void Engine::close_cuts(Lane& L) {
  for (int c = 0; c < static_cast<int>(charts_.size()); ++c)
    if (C(c).alive && !C(c).locked)
      for (const auto& chain : cut_chains(c)) rep_.cut_edges_in += chain.size();
  // Each chart's cuts, cheapest first (mean distance between the two sides' wedges); after a closed
  // cut the chart's chains are found again (a closing can join or end chains). A chain is tried
  // whole, then without its last or its first edge when the whole would change the topology (a cut
  // between two ends inside a closed chart: all but one edge can close).
  for (int c = 0; c < static_cast<int>(charts_.size()); ++c) {
    if (!C(c).alive || C(c).locked) continue;
    std::set<std::vector<int>> refused;
    bool again = true;
    while (again) {
      again = false;
      std::vector<std::pair<double, std::vector<int>>> todo;
      for (std::vector<int>& chain : cut_chains(c)) {
        std::vector<std::pair<int, int>> pairs;
        double gap = 0;
        for (int ei : chain) {
          const Edge& e = topo_.edges[static_cast<size_t>(ei)];
          const EdgeIncidence& x = topo_.edge_faces[static_cast<size_t>(e.first_incidence)];
          const EdgeIncidence& y = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
          for (int v : {e.a, e.b})
            gap += (at_.wedge_uv[static_cast<size_t>(wedge(x.face, corner_of(x.face, v)))] -
                    at_.wedge_uv[static_cast<size_t>(wedge(y.face, corner_of(y.face, v)))]).norm();
        }
        todo.emplace_back(gap / (2.0 * static_cast<double>(chain.size())), std::move(chain));
      }
      std::stable_sort(todo.begin(), todo.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (const auto& item : todo) {
        const std::vector<int>& chain = item.second;
        std::vector<std::vector<int>> tries{chain};
        if (chain.size() >= 2) {
          tries.emplace_back(chain.begin(), chain.end() - 1);
          tries.emplace_back(chain.begin() + 1, chain.end());
        }
        for (size_t i = 0; i < tries.size() && !again; ++i) {
          std::vector<int> key = tries[i];
          std::sort(key.begin(), key.end());
          if (refused.count(key)) continue;
          std::string reason;
          if (try_close(c, tries[i], reason, L)) {
            again = true;
          } else {
            refused.insert(key);
            ++L.rep.cut_rejected[reason];
            if (reason != "topology") break;  // only a topology refusal tries the shorter chains
          }
        }
        if (again) break;
      }
    }
  }
}

}  // namespace texdefrag::merge::detail
