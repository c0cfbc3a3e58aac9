// The merge engine's set-up, queue and passes (docs/mergers.md steps 1-2, 8-9). One move is in
// engine_move.cpp.
#include "engine_internal.h"

#include "texdefrag/core/distortion.h"

#include "texdefrag/util/memory.h"
#include "texdefrag/util/parallel.h"

#include <atomic>
#include <chrono>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>
#include <thread>

namespace texdefrag::merge::detail {

void CellGrid::insert(int id, std::array<int, 4>& r) {
  if (static_cast<long long>(r[2] - r[0] + 1) * (r[3] - r[1] + 1) > kMaxTriCells) {
    r = {1, 1, 0, 0};
    big.push_back(id);
    return;
  }
  for (int y = r[1]; y <= r[3]; ++y)
    for (int x = r[0]; x <= r[2]; ++x) cells[key(x, y)].push_back(id);
}

void CellGrid::remove(int id, const std::array<int, 4>& r) {
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

namespace {
const char* kRefusal[] = {"", "seam_too_short", "alignment_error"};
}  // namespace

void Engine::setup() {
  const size_t nf = mesh_.faces.size();
  if (at_.face_chart.size() != nf || at_.face_wedge.size() != nf)
    throw std::invalid_argument("merge engine: atlas does not match the mesh");
  if (!region_.empty() && region_.size() != nf)
    throw std::invalid_argument("merge engine: face_region has " + std::to_string(region_.size()) +
                                " entries for " + std::to_string(nf) + " faces");
  check_cancel();
  setup_rest_shapes();
  check_cancel();
  setup_charts();
  check_cancel();
  setup_seams_and_grids();
}

void Engine::check_watch() {
  if (!watch_ || !(weight_sum_ > 0) || main_.err_sum < watch_at_ * weight_sum_) return;
  const std::function<void()> f = std::move(watch_);
  watch_ = nullptr;
  f();
}

void Engine::setup_rest_shapes() {
  const size_t nf = mesh_.faces.size();
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
  fmirror_.assign(nf, 0);
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
  open_thin_faces();
  for (size_t f = 0; f < nf; ++f) {
    if (rest_w_[f] == 0) continue;
    err_w_[f] = weighted_err(static_cast<int>(f));
    main_.err_sum += err_w_[f];
  }
  rep_.distortion_in = weight_sum_ > 0 ? main_.err_sum / weight_sum_ : 0;
}

double Engine::oriented_altitude(int f) const {
  const Vec2& a = at_.wedge_uv[static_cast<size_t>(wedge(f, 0))];
  const Vec2& b = at_.wedge_uv[static_cast<size_t>(wedge(f, 1))];
  const Vec2& c = at_.wedge_uv[static_cast<size_t>(wedge(f, 2))];
  const double twice = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  const double len = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const double sign = rest_inv_[static_cast<size_t>(f)].determinant() > 0 ? 1 : -1;
  return len > 0 ? sign * twice / len : 0;
}

void Engine::open_thin_faces() {
  // note: a sub-texel sliver (Matterport's Draco GLBs hold 5-13 per room, altitude about 1e-6 texel)
  // keeps its orientation in doubles, but once its chart is turned by the packer and written as
  // float32 its triangle has zero or negative area (eval counted them as flipped faces). Opening it to
  // kThinAltitude costs ARAP error (its Jacobian stretches it by kThinAltitude / altitude), weighted by
  // its tiny input UV area; the engine counts that cost from the start, against the true input.
  const size_t nf = mesh_.faces.size();
  fthin_.assign(nf, 0);
  std::vector<std::array<int, 4>> closed;  // (face, i, j, k): thin faces still to open
  for (size_t f = 0; f < nf; ++f) {
    if (rest_w_[f] == 0) continue;
    std::array<Vec2, 3> P;
    for (int k = 0; k < 3; ++k) P[static_cast<size_t>(k)] = mesh_.corner_texel(f, k);
    size_t i = 0;
    double len = -1;
    for (size_t k = 0; k < 3; ++k) {
      const double l = (P[(k + 1) % 3] - P[k]).norm();
      if (l > len) {
        len = l;
        i = k;
      }
    }
    if (!(len > 0) || 2 * rest_w_[f] / len >= kThinAltitude) continue;
    ++rep_.thin_faces;
    const int fi = static_cast<int>(f);
    const size_t j = (i + 1) % 3, k = (i + 2) % 3;
    // The target: the corner opposite the longest edge moved out, on its side, to kThinAltitude.
    const Vec2 e = (P[j] - P[i]) / len, n(-e.y(), e.x());
    const double h = e.x() * (P[k] - P[i]).y() - e.y() * (P[k] - P[i]).x();
    std::array<Vec2, 3> Q = P;
    Q[k] += ((h >= 0 ? 1 : -1) * kThinAltitude - h) * n;
    Mat2 Dm;
    Dm.col(0) = Q[1] - Q[0];
    Dm.col(1) = Q[2] - Q[0];
    fthin_[f] = 1;
    thin_inv_[fi] = Dm.inverse();
    if (oriented_altitude(fi) < kThinAltitude)
      closed.push_back({fi, static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)});
  }
  // note: opening a sliver may be refused because it would close a neighbouring sliver that shares
  // the wedge (seen on a Cedar Creek room: two slivers 1e-5 texel high side by side); once that one is
  // open, the first may open too. Rounds until one opens nothing.
  // note: opening moves a wedge by up to kThinAltitude, which can push a sliver into a triangle of its
  // chart that is not its neighbour (Cedar Creek lod0_room6: 6 pairs more than the input, which the
  // pipeline refused); the faces of each chart holding a closed sliver are gathered for that test.
  std::map<int, std::vector<int>> chart_faces;
  for (const auto& cl : closed) chart_faces[chart(cl[0])];
  for (size_t f = 0; f < nf; ++f) {
    if (at_.face_chart[f] < 0 || mesh_.faces[f].page == kNoPage) continue;
    auto it = chart_faces.find(chart(static_cast<int>(f)));
    if (it != chart_faces.end()) it->second.push_back(static_cast<int>(f));
  }
  // A sliver that cannot open to kThinAltitude without adding an overlap is opened to half of it
  // (the floor every changed face keeps; Cedar Creek lod0_room2: 13 -> 14 of 17 open).
  for (double alt : {kThinAltitude, 0.5 * kThinAltitude}) open_thin_rounds(closed, chart_faces, alt);
  for (size_t f = 0; f < nf; ++f)
    if (fthin_[f]) {
      const int fi = static_cast<int>(f);
      thin_alt_[fi] = std::min(0.5 * kThinAltitude, std::max(0.0, oriented_altitude(fi)));
    }
}

void Engine::open_thin_rounds(std::vector<std::array<int, 4>>& closed, std::map<int, std::vector<int>>& chart_faces,
                              double alt) {
  for (size_t opened = 1; opened > 0 && !closed.empty();) {
    opened = 0;
    std::vector<std::array<int, 4>> still;
    for (const auto& [fi, i, j, k] : closed) {
      // The corner opposite the longest edge first, then either end of that edge.
      const std::vector<int>& cf = chart_faces[chart(fi)];
      if (open_thin_wedge(fi, i, j, k, cf, alt) || open_thin_wedge(fi, j, k, i, cf, alt) ||
          open_thin_wedge(fi, k, i, j, cf, alt))
        ++opened;
      else
        still.push_back({fi, i, j, k});
    }
    rep_.thin_faces_opened += opened;
    closed.swap(still);
  }
}

bool Engine::open_thin_wedge(int fi, int i, int j, int k, const std::vector<int>& chart_faces, double alt) {
  // The atlas: the move of open_thin_faces on the current triangle (corner k out from edge i-j),
  // kept when no other face using that wedge closes below min(its altitude before, alt).
  const int w = wedge(fi, k);
  const Vec2 a = uv(wedge(fi, i)), b = uv(wedge(fi, j)), old = uv(w);
  const double lb = (b - a).norm();
  if (!(lb > 0)) return false;
  // Corner k's height over edge (i, j) that gives the triangle's smallest altitude alt
  // (twice the area over the longest edge; alt itself when (i, j) is the longest).
  const double height = alt * std::max({lb, (old - a).norm(), (old - b).norm()}) / lb;
  const Vec2 eb = (b - a) / lb, nb(-eb.y(), eb.x());
  const double sd = eb.x() * (old - a).y() - eb.y() * (old - a).x();
  const double side = rest_inv_[static_cast<size_t>(fi)].determinant() > 0 ? 1 : -1;  // its rest shape's turn
  std::vector<std::pair<int, double>> others;
  std::vector<int> moved;
  faces_of_wedge(w, chart(fi), [&](int g, int) {
    moved.push_back(g);
    if (g != fi && rest_w_[static_cast<size_t>(g)] > 0) others.emplace_back(g, oriented_altitude(g));
  });
  uv(w) = old + (side * height - sd) * nb;
  bool ok = oriented_altitude(fi) > 0;
  for (const auto& [g, before] : others) ok = ok && oriented_altitude(g) >= std::min(before, alt);
  ok = ok && !wedge_move_adds_overlap(w, old, moved, chart_faces);
  if (!ok) uv(w) = old;
  return ok;
}

bool Engine::wedge_move_adds_overlap(int w, const Vec2& old, const std::vector<int>& moved,
                                     const std::vector<int>& chart_faces) const {
  std::vector<Tri2> mv, all;
  mv.reserve(moved.size());
  all.reserve(chart_faces.size());
  for (int g : moved) mv.push_back(tri2(g));
  for (int h : chart_faces) all.push_back(tri2(h));
  // note: the input's slivers often overlap a neighbour by a sliver of area (1e-9 texel^2 and less),
  // which the pipeline's count does not see (pairs over kCountedOverlapArea); opened, the same pair can
  // cover 1e-4 texel^2 (Cedar Creek lod0_room5: 4 pairs more). So a pair counts when its area grows
  // past that threshold, not only when it did not overlap before.
  auto before = [&](Tri2 t) {
    for (size_t k = 0; k < 3; ++k)
      if (t.w[k] == w) t.p[k] = old;
    return t;
  };
  return any_triangle_overlap(mv, all, 0, [&](const Tri2& a, const Tri2& b) {
    return crosses_counted_overlap(before(a), before(b), a, b);
  });
}

void Engine::setup_charts() {
  const size_t nf = mesh_.faces.size();
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
  std::vector<detectors::PlaneMoments> rmom(static_cast<size_t>(nregions));
  ebnd_.assign(3 * nf, 0);
  std::vector<std::map<int, int>> votes(static_cast<size_t>(nc));
  for (size_t f = 0; f < nf; ++f) {
    const int c = at_.face_chart[f];
    if (c < 0) continue;
    ChartInfo& ch = C(c);
    ch.page = at_.chart_page[static_cast<size_t>(c)];
    ch.faces.push_back(static_cast<int>(f));
    ch.uv_area += rest_w_[f];
    if (rest_w_[f] > 0) {
      const double sa = signed_uv_area(static_cast<int>(f));
      ch.turn += rest_w_[f] * ((sa > 0) - (sa < 0));
    }
    ch.page_area[mesh_.faces[f].page] += rest_w_[f];
    if (topo_.face_degenerate[f]) ch.locked = true;
    detectors::PlaneMoments m;
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
  for (size_t r = 0; r < rmom.size(); ++r) region_normal_[r] = detectors::fit_plane(rmom[r]).normal;
  for (int c = 0; c < nc; ++c) {
    ChartInfo& ch = C(c);
    int best = -1, bestn = 0;
    for (const auto& [r, n] : votes[static_cast<size_t>(c)])
      if (n > bestn) {
        best = r;
        bestn = n;
      }
    ch.region = best;
    // Each input chart is one group of the framework's flip measure, as laid out in the input.
    if (ch.uv_area > 0) ++ch.groups[0][ch.turn > 0 ? 2 : ch.turn < 0 ? 0 : 1];
    if (ch.locked) ++rep_.locked_charts;
    refresh_planarity(c);
  }
  mark_self_overlapping_charts();
}

void Engine::mark_self_overlapping_charts() {
  // Input charts whose triangles already overlap (photogrammetry charts can be multi-sheeted): the
  // boundary-crossing test does not see a merge that lands on another sheet, so merges touching
  // them also test triangles (see try_merge). Each chart is tested on its own: blocks of charts side
  // by side (1.2 s of one thread on the 1M-face synthetic factory's 90,968 charts).
  const size_t nc = charts_.size();
  constexpr size_t kBlock = 256;
  std::vector<char> overlap(nc, 0);
  parallel_for((nc + kBlock - 1) / kBlock, [&](size_t b) {
    std::vector<Tri2> tris;
    for (size_t c = b * kBlock; c < std::min(nc, (b + 1) * kBlock); ++c) {
      const ChartInfo& ch = charts_[c];
      if (ch.faces.size() < 2) continue;
      tris.clear();
      for (int f : ch.faces)
        if (rest_w_[static_cast<size_t>(f)] > 0) tris.push_back(tri2(f));
      overlap[c] = any_triangle_overlap(tris, {}) ? 1 : 0;
    }
  });
  for (size_t c = 0; c < nc; ++c) {
    charts_[c].self_overlap = overlap[c] != 0;
    if (charts_[c].self_overlap) ++rep_.self_overlapping_charts;
  }
}

template <class Fn>
void Engine::for_each_textured_edge(Fn&& fn) const {
  for (size_t ei = 0; ei < topo_.edges.size(); ++ei) {
    const Edge& e = topo_.edges[ei];
    if (e.num_faces != 2 || e.a == e.b) continue;
    const EdgeIncidence& x = topo_.edge_faces[static_cast<size_t>(e.first_incidence)];
    const EdgeIncidence& y = topo_.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
    const int ca = chart(x.face), cb = chart(y.face);
    if (ca < 0 || cb < 0) continue;
    if (topo_.face_degenerate[static_cast<size_t>(x.face)] || topo_.face_degenerate[static_cast<size_t>(y.face)])
      continue;
    fn(ei, e, x.face, y.face, ca, cb);
  }
}

double Engine::edges_length_3d(const std::vector<int>& edges) const {
  double len = 0;
  for (int ei : edges) {
    const Edge& e = topo_.edges[static_cast<size_t>(ei)];
    len += (mesh_.positions[static_cast<size_t>(topo_.position_of_vertex[static_cast<size_t>(e.a)])] -
            mesh_.positions[static_cast<size_t>(topo_.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
  }
  return len;
}

void Engine::rebuild_adjacency() {
  for (ChartInfo& ch : charts_) ch.adj.clear();
  // Seam edges: manifold, two textured non-degenerate faces in different charts.
  for_each_textured_edge([&](size_t ei, const Edge&, int, int, int ca, int cb) {
    if (ca == cb) return;
    C(ca).adj[cb].push_back(static_cast<int>(ei));
    C(cb).adj[ca].push_back(static_cast<int>(ei));
  });
}

void Engine::setup_seams_and_grids() {
  const size_t nf = mesh_.faces.size();
  rebuild_adjacency();
  wstamp_.assign(at_.wedge_uv.size(), 0);
  wmoved_.assign(at_.wedge_uv.size(), 0);
  wdist_.assign(at_.wedge_uv.size(), 0);
  wvisit_.assign(at_.wedge_uv.size(), 0);
  wfan_.assign(at_.wedge_uv.size(), 0);
  wrep_.assign(at_.wedge_uv.size(), 0);
  wdone_.assign(at_.wedge_uv.size(), 0);
  wlocal_.assign(at_.wedge_uv.size(), 0);
  wlocal_stamp_.assign(at_.wedge_uv.size(), 0);
  fstamp_.assign(nf, 0);
  fchanged_.assign(nf, 0);
  fsmall_.assign(nf, 0);
  fshape_.assign(nf, 0);
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
  eowner_.assign(3 * nf, -1);
  ecells_.assign(3 * nf, {1, 1, 0, 0});
  edead_.assign(3 * nf, 0);
  emoved_.assign(3 * nf, 0);
  eseen_.assign(3 * nf, 0);
  // Each chart's grids get its faces and boundary edges in the order of ChartInfo::faces (face
  // order) and ChartInfo::boundary, whatever thread fills them: blocks of charts side by side
  // (0.43 s of one thread on the 1M-face synthetic factory).
  const size_t nc = static_cast<size_t>(at_.num_charts);
  constexpr size_t kBlock = 256;
  parallel_for((nc + kBlock - 1) / kBlock, [&](size_t b) {
    for (size_t c = b * kBlock; c < std::min(nc, (b + 1) * kBlock); ++c) {
      const int ci = static_cast<int>(c);
      for (int f : C(ci).faces)
        if (rest_w_[static_cast<size_t>(f)] > 0) grid_insert(ci, f);
      for (const auto& [f, k] : C(ci).boundary) seg_insert(ci, 3 * f + k);
    }
  });
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

void Engine::refresh_planarity(int c) {
  // One planarity module for detectors and mergers (detectors/common/planarity.h): normals oriented
  // by the faces' 3D winding, theta in [0, pi], the normal term 0 past 90 degrees.
  ChartInfo& ch = C(c);
  const detectors::PlaneFit fit = detectors::fit_plane(ch.mom);
  const Vec3 rn = ch.region >= 0 ? region_normal_[static_cast<size_t>(ch.region)] : Vec3::Zero();
  ch.planarity = fit.valid ? detectors::planarity_index(fit, detectors::normal_angle(fit.normal, rn), opt_.weights) : 0.0;
}

bool Engine::candidate(int a, int b) const {
  const ChartInfo& A = charts_[static_cast<size_t>(a)];
  const ChartInfo& B = charts_[static_cast<size_t>(b)];
  // note: the region test first: in the first pass a chart of another region belongs to another lane,
  // whose thread may be changing its other fields (region and locked never change).
  if (a == b || !(across_ || (A.region >= 0 && A.region == B.region))) return false;
  return A.alive && B.alive && !A.locked && !B.locked && (opt_.cross_page || A.page == B.page);
}

void Engine::pair_points(int big, int small, std::vector<std::pair<int, int>>& pairs) {
  seam_pairs(big, C(big).adj[small], pairs);
}

void Engine::seam_pairs(int big, const std::vector<int>& edges, std::vector<std::pair<int, int>>& pairs) {
  pairs.clear();
  for (int ei : edges) {
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
  // In the first pass the visit stays in a's region: reaching a chart of another region (or of none)
  // other than c ends it unsuccessfully, so it never reads another lane's adjacency. Such charts are
  // known by their ids at the start of the pass (their lanes' merges do not update a's lists).
  auto outside = [&](int c) { return !across_ && charts_[static_cast<size_t>(c)].region != A.region; };
  for (int c : nab) {
    std::vector<int> stack{a}, visited{c, a};
    int steps = 0;
    bool blocked = false;
    auto seen = [&](int x) { return std::find(visited.begin(), visited.end(), x) != visited.end(); };
    while (!stack.empty() && steps <= max_steps && !blocked) {
      const int sc = stack.back();
      stack.pop_back();
      if (!seen(sc)) visited.push_back(sc);
      for (int ac : sorted_neighbours(sc)) {
        if (!seen(ac)) {
          if (outside(ac)) {
            blocked = true;
            break;
          }
          stack.push_back(ac);
          ++steps;
        }
        if (steps > max_steps) break;
      }
    }
    if (!blocked && stack.empty()) return true;  // the component of a without c has c as its only neighbour
  }
  return false;
}

void Engine::seam_figures(Lane& L, int a, int big, int small, double& err, double& la, double& lb) {
  std::vector<std::pair<int, int>>& pairs = L.score_pairs;
  pair_points(big, small, pairs);
  std::vector<Vec2>& p = L.score_p;
  std::vector<Vec2>& q = L.score_q;
  p.clear();
  q.clear();
  for (const auto& [wb, ws] : pairs) {
    q.push_back(uv(wb));
    p.push_back(uv(ws));
  }
  const Rigid2 m = seam_mirrored(big, small) ? fit_improper(p, q) : fit_rigid(p, q);
  err = 0;
  for (size_t i = 0; i < p.size(); ++i) err += (m(p[i]) - q[i]).norm();
  err /= static_cast<double>(std::max<size_t>(1, p.size()));
  la = lb = 0;
  const int b = big == a ? small : big;
  for (int ei : C(a).adj[b]) {
    const Edge& ed = topo_.edges[static_cast<size_t>(ei)];
    for (int i = 0; i < 2; ++i) {
      const EdgeIncidence& in = topo_.edge_faces[static_cast<size_t>(ed.first_incidence + i)];
      (chart(in.face) == a ? la : lb) += edge_uv_len(in.face, in.local);
    }
  }
}

double Engine::score(Lane& L, int a, int b, int& refusal) {
  ChartInfo& A = C(a);
  ChartInfo& B = C(b);
  refusal = 0;
  if (opt_.priority == Priority::Planarity)
    return std::max(A.planarity, B.planarity) * std::max(A.uv_area, B.uv_area);
  // M-method cost: err * min(B_a/L_a, B_b/L_b) * min(area_a, area_b) * penalty, smaller first.
  const int big = A.uv_area >= B.uv_area ? a : b, small = big == a ? b : a;
  PairState& ps = L.pair_state(a, b);
  const std::vector<int>& seam = A.adj[b];
  const size_t nedges = seam.size();
  if (!seam_current(ps, big, seam)) {
    seam_figures(L, a, big, small, ps.seam_err, ps.seam_la, ps.seam_lb);
    ps.seam_big = big;
    ps.seam_edges = nedges;
    ps.seam_clock = L.shape_clock;
  } else {
    ++L.rep.seam_figures_kept;
    if (opt_.check_kept_seams) {
      double e, x, y;
      seam_figures(L, a, big, small, e, x, y);
      if (e != ps.seam_err || x != ps.seam_la || y != ps.seam_lb)
        throw std::logic_error("merge engine: the kept seam figures of charts " + std::to_string(a) + " and " +
                               std::to_string(b) + " differ from the seam's");
    }
  }
  const double err = ps.seam_err, la = ps.seam_la, lb = ps.seam_lb;
  const double ra = la > 0 ? A.border / la : 1e30, rb = lb > 0 ? B.border / lb : 1e30;
  const double cost = err * std::min(ra, rb) * std::min(A.uv_area, B.uv_area) * ps.penalty;
  // note: the M-method program refuses when the mean pair distance exceeds 2 x the mean of the seam's
  // two UV lengths (its matching threshold times the whole seam), not 2 x one edge.
  const double seam_len = 0.5 * (la + lb);
  const double mean_seam = opt_.alignment_per_edge ? (nedges ? seam_len / static_cast<double>(nedges) : 0) : seam_len;
  if (la < 0.2 * A.border && lb < 0.2 * B.border && !(across_ && !opt_.second_pass_seam_refusal) &&
      !island_lookahead(a, b, kIslandLookaheadSteps))
    refusal = 1;
  else if (err > 2 * mean_seam)
    refusal = 2;
  return -cost;
}

bool Engine::seam_current(const PairState& ps, int big, const std::vector<int>& seam) const {
  if (ps.seam_big != big || ps.seam_edges != seam.size()) return false;
  for (int ei : seam) {
    const Edge& ed = topo_.edges[static_cast<size_t>(ei)];
    for (int i = 0; i < 2; ++i)
      if (fshape_[static_cast<size_t>(topo_.edge_faces[static_cast<size_t>(ed.first_incidence + i)].face)] > ps.seam_clock)
        return false;
  }
  return true;
}

void Engine::mark_shapes(Lane& L, const Lane& log, int big) {
  // Every corner a move changes is in its rollback log: a wedge moved (saved_uv: the faces of the
  // merged chart still using it) or a corner repointed (saved_fw: every face whose wedges changed).
  const int t = ++L.shape_clock;
  for (const auto& [w, p] : log.saved_uv) faces_of_wedge(w, big, [&](int f, int) { fshape_[static_cast<size_t>(f)] = t; });
  for (const auto& [f, fw] : log.saved_fw) fshape_[static_cast<size_t>(f)] = t;
}

void Engine::push_pair(Lane& L, int a, int b) {
  if (a > b) std::swap(a, b);
  if (!candidate(a, b)) return;
  PairState& ps = L.pair_state(a, b);
  if (ps.attempts >= opt_.max_attempts) return;
  if (ps.va == C(a).version && ps.vb == C(b).version) return;  // its newest entry is current
  Entry e{0, a, b, C(a).version, C(b).version, 0};
  // Scoring reads the two charts' UVs: a speculative move of them must leave the atlas first.
  if (speculating_) drop_speculations_of(a, b, true);
  e.score = score(L, a, b, e.refusal);
  ps.va = e.va;
  ps.vb = e.vb;
  L.queue.push(e);
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

void add_counters(MergeReport& to, const MergeReport& from) {
  to.candidates_initial += from.candidates_initial;
  to.attempted += from.attempted;
  to.accepted += from.accepted;
  to.accepted_mirrored += from.accepted_mirrored;
  for (const auto& [k, v] : from.rejected) to.rejected[k] += v;
  to.fan_target_moves += from.fan_target_moves;
  to.repairs_tried += from.repairs_tried;
  to.repairs_untangled += from.repairs_untangled;
  to.repairs_accepted += from.repairs_accepted;
  to.partial_weld_retries += from.partial_weld_retries;
  to.partial_welds_accepted += from.partial_welds_accepted;
  to.hole_fill_retries += from.hole_fill_retries;
  to.hole_fills_accepted += from.hole_fills_accepted;
  to.holes_filled += from.holes_filled;
  to.fan_hold_retries += from.fan_hold_retries;
  to.fan_holds_accepted += from.fan_holds_accepted;
  to.cuts_attempted += from.cuts_attempted;
  to.cuts_closed += from.cuts_closed;
  to.cut_edges_closed += from.cut_edges_closed;
  for (const auto& [k, v] : from.cut_rejected) to.cut_rejected[k] += v;
  to.optimisation_seconds += from.optimisation_seconds;
  to.check_seconds += from.check_seconds;
  to.seam_figures_kept += from.seam_figures_kept;
}

MergeReport Engine::run(const Progress& progress) {
  setup();
  refreshed_area_.resize(charts_.size());
  for (size_t c = 0; c < charts_.size(); ++c) refreshed_area_[c] = charts_[c].uv_area;
  const bool second = opt_.second_pass == SecondPass::AcrossRegions;
  // Two entries per thread: move costs are uneven (a few large free regions), so a thread that
  // finishes a short move takes the next one of the batch (t016_L19, 2 threads: 22% of the pass's
  // CPU beside its longest moves with batches of 2, 33% with 4 and 8).
  const int threads = thread_count();
  spec_width_ = opt_.second_pass_batch > 0 ? opt_.second_pass_batch : threads > 1 ? 2 * threads : 1;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  first_pass(progress, second ? 0.6 : 1.0);
  rep_.first_pass_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (overspent_) return rep_;  // the atlas is as it was given; run_merges runs again with shares
  rep_.charts_after_first_pass = 0;
  for (const ChartInfo& ch : charts_) rep_.charts_after_first_pass += ch.alive && !ch.faces.empty();
  rep_.distortion_after_first_pass = global_distortion();
  check_watch();
  if (second) {
    const auto t1 = Clock::now();
    const double c1 = process_cpu_seconds();
    main_.max_merges = opt_.max_merges;
    const size_t before = main_.rep.accepted, attempted_before = main_.rep.attempted;
    const int steps = std::max(1, opt_.second_pass_steps);
    for (int i = 0; i < steps; ++i) {
      start_second_pass(opt_.second_pass_local_bound / std::pow(2.0, steps - 1 - i));
      drain(main_, progress, 0.6 + 0.4 * i / steps, 0.4 / steps);
    }
    rep_.accepted_second_pass = main_.rep.accepted - before;
    rep_.attempted_second_pass = main_.rep.attempted - attempted_before;
    rep_.second_pass_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
    rep_.second_pass_cpu_seconds = process_cpu_seconds() - c1;
  }
  if (opt_.close_cuts) {
    const auto t2 = Clock::now();
    close_cuts(main_);
    rep_.close_cuts_seconds = std::chrono::duration<double>(Clock::now() - t2).count();
    check_watch();
  }
  if (progress) progress(1.0);
  measure_seams_left();
  add_counters(rep_, main_.rep);
  rep_.mean_free_vertices = main_.free_count ? main_.free_total / static_cast<double>(main_.free_count) : 0;
  rep_.charts_out = static_cast<size_t>(at_.compact());
  std::vector<int> own;
  if (!input_charts_.valid()) own = build_charts(mesh_, topo_).atlas.face_chart;
  const DistortionSummary ds = atlas_distortion(mesh_, at_, input_charts_.valid() ? input_charts_.get() : own);
  for (char m : fmirror_) rep_.mirrored_faces_out += m != 0;
  rep_.distortion_out = ds.arap;
  rep_.flipped_out = ds.flipped;
  return rep_;
}

void Engine::first_pass(const Progress& progress, double span) {
  if (opt_.seam_price == SeamPrice::On) {
    std::vector<int> seam;
    for_each_textured_edge([&](size_t ei, const Edge&, int, int, int ca, int cb) {
      if (ca != cb) seam.push_back(static_cast<int>(ei));
    });
    seam_in_3d_ = edges_length_3d(seam);
    price_on_ = true;
  }
  std::vector<Lane> lanes = make_region_lanes();
  rep_.first_pass_lanes = lanes.size();
  // Without budget shares the lanes skip the global check, and the pass stands when the global
  // distortion after it is within the bound (it is far under it on every model measured). Else the
  // atlas is restored and run_merges runs the engine again with shares, which always hold.
  const bool optimistic = lanes.size() > 1 && !budget_shares_;
  Atlas before;
  if (optimistic) before = at_;
  // note: one lane holding every candidate pair (the unconstrained trial's: no regions) drains alone on
  // this thread with the global check, as the second pass's main lane does: it speculates likewise.
  if ((opt_.first_pass_speculation || speculate_when_) && lanes.size() == 1 && lanes[0].global_check)
    solo_lane_ = &lanes[0];
  run_lanes(lanes, progress, span);
  solo_lane_ = nullptr;
  price_on_ = false;
  join_lanes(lanes);
  if (optimistic && global_distortion() > opt_.global_bound) {
    at_ = std::move(before);
    overspent_ = true;
  }
}

std::vector<Lane> Engine::make_region_lanes() {
  int nregions = 0;
  for (const ChartInfo& ch : charts_) nregions = std::max(nregions, ch.region + 1);
  std::vector<std::vector<int>> members(static_cast<size_t>(nregions));
  for (int c = 0; c < static_cast<int>(charts_.size()); ++c)
    if (C(c).region >= 0) members[static_cast<size_t>(C(c).region)].push_back(c);
  // With budget shares, each region's share of the global budget is proportional to its input UV
  // area, so the shares add up to the global bound whatever the lanes do.
  const double spare = opt_.global_bound * weight_sum_ - main_.err_sum;
  std::vector<Lane> lanes;
  for (int r = 0; r < nregions; ++r) {
    Lane L;
    L.region = r;
    L.epoch = main_.epoch;
    L.seen_stamp = main_.seen_stamp;
    for (int c : members[static_cast<size_t>(r)])
      for (const auto& [n, edges] : C(c).adj)
        if (c < n && candidate(c, n)) {
          ++L.rep.candidates_initial;
          push_pair(L, c, n);
        }
    if (L.queue.empty()) continue;
    double wr = 0;
    for (int c : members[static_cast<size_t>(r)])
      for (int f : C(c).faces) {
        wr += rest_w_[static_cast<size_t>(f)];
        L.err_sum += err_w_[static_cast<size_t>(f)];
      }
    L.global_check = false;
    if (budget_shares_) L.err_max = L.err_sum + (weight_sum_ > 0 ? spare * (wr / weight_sum_) : 0);
    lanes.push_back(std::move(L));
  }
  if (lanes.size() == 1) {
    // One region holds every candidate: its lane checks the global budget itself.
    lanes[0].err_sum = main_.err_sum;
    lanes[0].global_check = true;
  }
  return lanes;
}

void Engine::run_lanes(std::vector<Lane>& lanes, const Progress& progress, double span) {
  const size_t n = lanes.size();
  // A limit on merges that could bind makes the lanes depend on each other: they then run one after
  // the other in region order, each with what is left of the limit.
  const bool independent = opt_.max_merges >= static_cast<long long>(charts_.size());
  if (!independent || n < 2 || thread_count() < 2 || !solver_.reentrant()) {
    long long left = opt_.max_merges;
    for (size_t i = 0; i < n; ++i) {
      lanes[i].max_merges = left;
      drain(lanes[i], progress, span * static_cast<double>(i) / static_cast<double>(n), span / static_cast<double>(n));
      left -= static_cast<long long>(lanes[i].rep.accepted);
    }
    return;
  }
  // Biggest queues first (the pool hands items out in order); lanes never touch each other's charts.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t x, size_t y) { return lanes[x].queue.size() > lanes[y].queue.size(); });
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<size_t> done{0};
  parallel_for(n, [&](size_t i) {
    Lane& L = lanes[order[i]];
    L.max_merges = opt_.max_merges;
    // note: progress is reported from the calling thread only (the callback need not be thread-safe).
    const bool report = progress && std::this_thread::get_id() == caller;
    const double base = span * static_cast<double>(done.load()) / static_cast<double>(n);
    drain(L, report ? progress : Progress(), base, span / static_cast<double>(n));
    ++done;
  });
}

void Engine::join_lanes(std::vector<Lane>& lanes) {
  bool stale = false;
  for (Lane& L : lanes) {
    add_counters(main_.rep, L.rep);
    main_.free_total += L.free_total;
    main_.free_count += L.free_count;
    if (main_.pairs.empty()) {
      main_.pairs = std::move(L.pairs);
    } else {
      for (const auto& [key, ps] : L.pairs) main_.pairs[key] = ps;
    }
    main_.epoch = std::max(main_.epoch, L.epoch);
    main_.seen_stamp = std::max(main_.seen_stamp, L.seen_stamp);
    main_.shape_clock = std::max(main_.shape_clock, L.shape_clock);
    stale = stale || L.stale_adjacency;
  }
  if (lanes.size() == 1 && lanes[0].global_check) {
    main_.err_sum = lanes[0].err_sum;
  } else if (!lanes.empty()) {
    // note: summed again in face order: the lanes' sums in any order would round differently.
    main_.err_sum = 0;
    for (double e : err_w_) main_.err_sum += e;
  }
  if (stale) rebuild_adjacency();
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
  for (auto& [key, ps] : main_.pairs) {
    ps.va = ps.vb = -1;
    ps.seam_big = -1;  // rebuild_adjacency may have reordered the seams' edges (la, lb add in their order)
    if (!first_step) ps.attempts = 0;  // a later step has a looser local bound: try again
  }
  for (int c = 0; c < static_cast<int>(charts_.size()); ++c) {
    if (!C(c).alive) continue;
    std::vector<int> nb;
    for (const auto& [n, edges] : C(c).adj)
      if (c < n) nb.push_back(n);
    for (int n : nb) push_pair(main_, c, n);
  }
}

void Engine::measure_seams_left() {
  std::set<long long> pairs;
  for_each_textured_edge([&](size_t, const Edge& e, int fx, int fy, int ca, int cb) {
    std::string why;
    if (ca == cb) {
      const int w0 = wedge(fx, corner_of(fx, e.a)), w1 = wedge(fx, corner_of(fx, e.b));
      const int g0 = wedge(fy, corner_of(fy, e.a)), g1 = wedge(fy, corner_of(fy, e.b));
      if (w0 == g0 && w1 == g1) return;  // not a seam
      why = "cut";
    } else if (!candidate(ca, cb)) {
      why = "not_candidate";
    } else {
      const auto it = main_.pairs.find(static_cast<long long>(std::min(ca, cb)) << 32 |
                                       static_cast<long long>(std::max(ca, cb)));
      why = it == main_.pairs.end() || it->second.last_reason.empty() ? "never_attempted" : it->second.last_reason;
    }
    MergeReport::SeamLeft& s = rep_.seam_left[why];
    ++s.edges;
    s.length_3d += (mesh_.positions[static_cast<size_t>(topo_.position_of_vertex[static_cast<size_t>(e.a)])] -
                    mesh_.positions[static_cast<size_t>(topo_.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
    if (pairs.insert(static_cast<long long>(std::min(ca, cb)) << 32 | static_cast<long long>(std::max(ca, cb))).second)
      ++s.pairs;
  });
}

void Engine::drain(Lane& L, const Progress& progress, double base, double span) {
  // The second pass evaluates entries side by side (engine_speculate.cpp); whatever way drain
  // leaves, no speculative move stays in the atlas.
  start_speculation(L);
  struct Stop {
    Engine& en;
    Lane& lane;
    ~Stop() { en.stop_speculation(lane); }
  } stop{*this, L};
  size_t popped = 0;
  while (!L.queue.empty() && static_cast<long long>(L.rep.accepted) < L.max_merges) {
    check_cancel();
    if (speculation_pending_ && speculate_when_->load(std::memory_order_relaxed)) start_speculation(L);
    const Entry e = L.queue.top();
    L.queue.pop();
    if ((++popped & 255) == 0 && progress)
      progress(base + span * static_cast<double>(popped) / static_cast<double>(popped + L.queue.size()));
    if (!C(e.a).alive || !C(e.b).alive) continue;
    if (C(e.a).version != e.va || C(e.b).version != e.vb) {
      // note: lazy refresh: a stale entry is re-scored and queued again (once per version pair).
      push_pair(L, e.a, e.b);
      continue;
    }
    PairState& ps = L.pair_state(e.a, e.b);
    if (ps.attempts >= opt_.max_attempts) continue;
    ++ps.attempts;
    if (e.refusal) {
      ++L.rep.rejected[kRefusal[e.refusal]];
      ps.last_reason = kRefusal[e.refusal];
      continue;
    }
    std::string reason;
    // note: take the small chart's neighbour list before the merge consumes it.
    const int big0 = C(e.a).uv_area >= C(e.b).uv_area ? e.a : e.b, small0 = big0 == e.a ? e.b : e.a;
    std::vector<int> fresh;
    for (const auto& [n, edges] : C(small0).adj)
      if (n != big0 && !C(big0).adj.count(n)) fresh.push_back(n);
    const Lane* log = nullptr;
    if (merge_entry(e, reason, L, log)) {
      ++L.rep.accepted;
      if (&L == &main_) check_watch();
      const int big = big0;
      mark_shapes(L, *log, big);
      ChartInfo& B = C(big);
      // Re-queue every pair of the merged chart when its area grew by a quarter since the last
      // full refresh (scores move little before that; stale entries are re-scored when popped);
      // always queue the pairs it inherited from the absorbed chart.
      if (B.uv_area > 1.25 * refreshed_area_[static_cast<size_t>(big)] || opt_.priority == Priority::MMethod) {
        refreshed_area_[static_cast<size_t>(big)] = B.uv_area;
        std::vector<int> nb;
        for (const auto& [n, edges] : B.adj) nb.push_back(n);
        for (int n : nb) push_pair(L, big, n);
      } else {
        for (int n : fresh) push_pair(L, big, n);
      }
    } else {
      ++L.rep.rejected[reason];
      ps.last_reason = reason;
      ps.penalty *= 2;  // the M-method's penalty (used by its cost only)
    }
  }
}

}  // namespace texdefrag::merge::detail
