// Hole filling (docs/mergers.md, "Hole filling"): temporary triangles over the holes of a
// merged chart, added to a merge's local problem only. A chart that is not a disk (an island chart
// left inside it, or a ring closed by the merge) has boundary loops besides its outer one; without
// faces across them the local solve may fold such a hole's border onto itself or squeeze the strip
// around it, which the acceptance checks then refuse. The M-method's program does the same for its
// ARAP shell (CloseHoles3D in its public source). The triangles never reach the atlas.
#include "engine_internal.h"
#include "geometry2d.h"

#include <unordered_set>

namespace texdefrag::merge::detail {

namespace {
/// Longest hole loop filled (ear clipping is quadratic in it); longer loops are left open.
constexpr size_t kMaxHoleLoop = 400;
/// Smallest altitude (texels) of a filling triangle; thinner ones are left out of the problem.
constexpr double kMinHoleAltitude = 0.25;
}  // namespace

bool Engine::trace_boundary_loop(int f, int k, int c, std::vector<int>& loop,
                                 std::unordered_set<long long>& seen) const {
  loop.clear();
  int cf = f, ck = k;
  do {
    if (!seen.insert(3LL * cf + ck).second || loop.size() >= kMaxHoleLoop) return false;
    loop.push_back(wedge(cf, ck));
    const int next_w = wedge(cf, (ck + 1) % 3);
    int n = 0, nf = -1, nk = -1;
    faces_of_wedge(next_w, c, [&](int g, int kk) {
      if (!is_boundary(g, kk, c)) return;
      ++n;
      nf = g;
      nk = kk;
    });
    if (n != 1) return false;  // a pinched wedge: the loop is not a simple polygon
    cf = nf;
    ck = nk;
  } while (cf != f || ck != k);
  std::unordered_set<int> distinct(loop.begin(), loop.end());
  return distinct.size() == loop.size() && loop.size() >= 3;
}

std::vector<std::vector<int>> Engine::hole_loops(const Move& mv) const {
  std::vector<std::vector<int>> holes;
  std::unordered_set<long long> seen;
  std::vector<int> loop;
  const std::unordered_set<int> free(mv.free_w.begin(), mv.free_w.end());
  for (int f : mv.prob_faces)
    for (int k = 0; k < 3; ++k) {
      if (seen.count(3LL * f + k) || !is_boundary(f, k, mv.big)) continue;
      if (!trace_boundary_loop(f, k, mv.big, loop, seen)) continue;
      if (std::none_of(loop.begin(), loop.end(), [&](int w) { return free.count(w) > 0; })) continue;
      // The outer loop runs with the chart's faces (same signed area sign), a hole's against them.
      double area2 = 0;
      for (size_t i = 0; i < loop.size(); ++i) {
        const Vec2 &p = at_.wedge_uv[static_cast<size_t>(loop[i])],
                   &q = at_.wedge_uv[static_cast<size_t>(loop[(i + 1) % loop.size()])];
        area2 += p.x() * q.y() - p.y() * q.x();
      }
      const Tri2 t = tri2(f);
      if (area2 * orient2d(t.p[0], t.p[1], t.p[2]) < 0) holes.push_back(loop);
    }
  return holes;
}

size_t Engine::add_hole_faces(const Move& mv, LocalProblem& lp, const std::function<int(int)>& local_of) const {
  size_t filled = 0;
  std::vector<Vec2> poly;
  std::vector<std::array<int, 3>> tris;
  for (std::vector<int>& loop : hole_loops(mv)) {
    std::reverse(loop.begin(), loop.end());  // now oriented as the chart's faces
    poly.clear();
    for (int w : loop) poly.push_back(at_.wedge_uv[static_cast<size_t>(w)]);
    if (!ear_clip(poly, tris)) continue;
    bool added = false;
    for (const auto& t : tris) {
      const Vec2 &a = poly[static_cast<size_t>(t[0])], &b = poly[static_cast<size_t>(t[1])],
                 &c = poly[static_cast<size_t>(t[2])];
      const double area2 = std::abs(orient2d(a, b, c));
      const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
      if (area2 < kMinHoleAltitude * longest) continue;
      std::array<int, 3> local{};
      bool any_free = false;
      for (size_t j = 0; j < 3; ++j) {
        local[j] = local_of(loop[static_cast<size_t>(t[j])]);
        any_free = any_free || local[j] < lp.num_free;
      }
      if (!any_free) continue;
      Mat2 rest;
      rest.col(0) = b - a;
      rest.col(1) = c - a;
      lp.tri.push_back(local);
      lp.rest_inv.push_back(rest.inverse());
      lp.weight.push_back(0.5 * area2);
      added = true;
    }
    if (added) ++filled;
  }
  return filled;
}

}  // namespace texdefrag::merge::detail
