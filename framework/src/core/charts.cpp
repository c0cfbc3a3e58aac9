#include "texdefrag/core/charts.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <map>
#include <numeric>

namespace texdefrag {
namespace {

struct UnionFind {
  std::vector<int> p;
  explicit UnionFind(size_t n) : p(n) { std::iota(p.begin(), p.end(), 0); }
  int find(int x) {
    while (p[static_cast<size_t>(x)] != x) {
      p[static_cast<size_t>(x)] = p[static_cast<size_t>(p[static_cast<size_t>(x)])];
      x = p[static_cast<size_t>(x)];
    }
    return x;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) p[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
  }
};

bool same_tex(const TexturedMesh& m, int f, int k, int g, int l) {
  const int a = m.faces[static_cast<size_t>(f)].vt[static_cast<size_t>(k)];
  const int b = m.faces[static_cast<size_t>(g)].vt[static_cast<size_t>(l)];
  if (a == b) return true;
  return m.texcoords[static_cast<size_t>(a)] == m.texcoords[static_cast<size_t>(b)];
}

/// For a continuous pair, the corner of g matching corner (k) of f and corner (k+1) of f.
bool matching_corners(const Topology& t, int f, int k, int g, int l, int& gk, int& gk1) {
  const auto& fv = t.face_vertex[static_cast<size_t>(f)];
  const auto& gv = t.face_vertex[static_cast<size_t>(g)];
  const int fa = fv[static_cast<size_t>(k)], fb = fv[static_cast<size_t>((k + 1) % 3)];
  const int ga = gv[static_cast<size_t>(l)], gb = gv[static_cast<size_t>((l + 1) % 3)];
  if (fa == ga && fb == gb) { gk = l; gk1 = (l + 1) % 3; return true; }
  if (fa == gb && fb == ga) { gk = (l + 1) % 3; gk1 = l; return true; }
  return false;
}

}  // namespace

bool uv_continuous(const TexturedMesh& mesh, const Topology& topo, int f, int k, int g, int l) {
  const Face& F = mesh.faces[static_cast<size_t>(f)];
  const Face& G = mesh.faces[static_cast<size_t>(g)];
  if (F.page == kNoPage || G.page == kNoPage || F.page != G.page) return false;
  if (topo.face_degenerate[static_cast<size_t>(f)] || topo.face_degenerate[static_cast<size_t>(g)]) return false;
  int gk = 0, gk1 = 0;
  if (!matching_corners(topo, f, k, g, l, gk, gk1)) return false;
  return same_tex(mesh, f, k, g, gk) && same_tex(mesh, f, (k + 1) % 3, g, gk1);
}

int Atlas::compact() {
  std::vector<int> remap(static_cast<size_t>(num_charts), -1);
  std::vector<int> new_page;
  int n = 0;
  for (int& c : face_chart) {
    if (c < 0) continue;
    int& r = remap[static_cast<size_t>(c)];
    if (r < 0) {
      r = n++;
      new_page.push_back(chart_page[static_cast<size_t>(c)]);
    }
    c = r;
  }
  std::vector<int> wremap(wedge_uv.size(), -1);
  std::vector<Vec2> nuv;
  std::vector<int> nvert;
  for (auto& fw : face_wedge)
    for (int& w : fw) {
      if (w < 0) continue;
      int& r = wremap[static_cast<size_t>(w)];
      if (r < 0) {
        r = static_cast<int>(nuv.size());
        nuv.push_back(wedge_uv[static_cast<size_t>(w)]);
        nvert.push_back(wedge_vertex[static_cast<size_t>(w)]);
      }
      w = r;
    }
  wedge_uv.swap(nuv);
  wedge_vertex.swap(nvert);
  chart_page.swap(new_page);
  num_charts = n;
  return n;
}

std::vector<std::vector<int>> Atlas::chart_faces() const {
  std::vector<std::vector<int>> out(static_cast<size_t>(num_charts));
  for (size_t f = 0; f < face_chart.size(); ++f)
    if (face_chart[f] >= 0) out[static_cast<size_t>(face_chart[f])].push_back(static_cast<int>(f));
  return out;
}

double atlas_face_area(const Atlas& atlas, int f) {
  const auto& w = atlas.face_wedge[static_cast<size_t>(f)];
  if (w[0] < 0) return 0;
  const Vec2& a = atlas.wedge_uv[static_cast<size_t>(w[0])];
  const Vec2& b = atlas.wedge_uv[static_cast<size_t>(w[1])];
  const Vec2& c = atlas.wedge_uv[static_cast<size_t>(w[2])];
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

namespace {

// Per-chart sums for the plane fit, relative to the chart's first corner position ref.
struct ChartMoments {
  std::vector<Eigen::Matrix3d> second, pts2;  // area-weighted second moments; corner outer products
  std::vector<Vec3> first, ref, pts1;         // area-weighted first moments; reference; corner sums
  std::vector<uint8_t> has_ref;
  std::vector<int> npts;                      // corners summed in pts1/pts2
  explicit ChartMoments(size_t nc)
      : second(nc, Eigen::Matrix3d::Zero()), pts2(nc, Eigen::Matrix3d::Zero()), first(nc, Vec3::Zero()),
        ref(nc, Vec3::Zero()), pts1(nc, Vec3::Zero()), has_ref(nc, 0), npts(nc, 0) {}
};

// Adds face f of chart c to s (3D area) and to the moments m.
void add_face_moments(const TexturedMesh& mesh, size_t f, size_t c, ChartStats& s, ChartMoments& m) {
  if (!m.has_ref[c]) {
    m.ref[c] = mesh.corner_position(f, 0);
    m.has_ref[c] = 1;
  }
  const Vec3 a = mesh.corner_position(f, 0) - m.ref[c];
  const Vec3 b = mesh.corner_position(f, 1) - m.ref[c];
  const Vec3 cc = mesh.corner_position(f, 2) - m.ref[c];
  const double A = 0.5 * (b - a).cross(cc - a).norm();
  s.area_3d += A;
  const Vec3 sum = a + b + cc;
  m.first[c] += A * sum / 3.0;
  m.second[c] += A / 12.0 * (a * a.transpose() + b * b.transpose() + cc * cc.transpose() + sum * sum.transpose());
  for (const Vec3* p : {&a, &b, &cc}) {
    m.pts1[c] += *p;
    m.pts2[c] += *p * p->transpose();
    ++m.npts[c];
  }
}

// True when local edge k of face f (of chart c) is continued by another face of c in the atlas:
// the two corners share wedges at both endpoints.
bool interior_side(const Topology& topo, const Atlas& atlas, size_t f, int k, int c) {
  const Edge& e = topo.edges[static_cast<size_t>(topo.face_edge[f][static_cast<size_t>(k)])];
  bool interior = false;
  for (int i = 0; i < e.num_faces && !interior; ++i) {
    const EdgeIncidence& in = topo.edge_faces[static_cast<size_t>(e.first_incidence + i)];
    if (in.face == static_cast<int>(f) || atlas.face_chart[static_cast<size_t>(in.face)] != c) continue;
    const auto& fw = atlas.face_wedge[f];
    const auto& gw = atlas.face_wedge[static_cast<size_t>(in.face)];
    const int w0 = fw[static_cast<size_t>(k)], w1 = fw[static_cast<size_t>((k + 1) % 3)];
    const int g0 = gw[static_cast<size_t>(in.local)], g1 = gw[static_cast<size_t>((in.local + 1) % 3)];
    interior = (w0 == g0 && w1 == g1) || (w0 == g1 && w1 == g0);
  }
  return interior;
}

// Adds to s.uv_border the UV length of each side of face f (of chart c) that is a chart border.
void add_border_sides(const Topology& topo, const Atlas& atlas, size_t f, int c, ChartStats& s) {
  for (int k = 0; k < 3; ++k) {
    if (interior_side(topo, atlas, f, k, c)) continue;
    const Vec2& p = atlas.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][static_cast<size_t>(k)])];
    const Vec2& q = atlas.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][static_cast<size_t>((k + 1) % 3)])];
    s.uv_border += (p - q).norm();
  }
}

// Sets s.centroid, eigenvalues and (unoriented) normal of chart c from its moments: area-weighted,
// else from its corners when it has no 3D area; unchanged when it has neither.
void fit_plane(const ChartMoments& m, size_t c, ChartStats& s) {
  Eigen::Matrix3d cov;
  Vec3 mu;
  if (s.area_3d > 0) {
    mu = m.first[c] / s.area_3d;
    cov = m.second[c] / s.area_3d - mu * mu.transpose();
  } else if (m.npts[c] > 0) {
    mu = m.pts1[c] / m.npts[c];
    cov = m.pts2[c] / m.npts[c] - mu * mu.transpose();
  } else {
    return;
  }
  s.centroid = mu + m.ref[c];
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  s.eigenvalues = es.eigenvalues().cwiseMax(0.0);
  s.normal = es.eigenvectors().col(0);
}

// Orients each chart's plane normal with the chart's area-weighted face normals.
void orient_normals(const TexturedMesh& mesh, const Atlas& atlas, std::vector<ChartStats>& st) {
  const size_t nc = st.size();
  std::vector<Vec3> nsum(nc, Vec3::Zero());
  for (size_t f = 0; f < atlas.face_chart.size(); ++f) {
    const int c = atlas.face_chart[f];
    if (c < 0) continue;
    const Vec3& a = mesh.corner_position(f, 0);
    nsum[static_cast<size_t>(c)] += (mesh.corner_position(f, 1) - a).cross(mesh.corner_position(f, 2) - a);
  }
  for (size_t c = 0; c < nc; ++c)
    if (st[c].normal.dot(nsum[c]) < 0) st[c].normal = -st[c].normal;
}

}  // namespace

std::vector<ChartStats> chart_stats(const TexturedMesh& mesh, const Topology& topo, const Atlas& atlas) {
  const size_t nc = static_cast<size_t>(atlas.num_charts);
  std::vector<ChartStats> st(nc);
  ChartMoments moments(nc);
  for (size_t f = 0; f < atlas.face_chart.size(); ++f) {
    const int c = atlas.face_chart[f];
    if (c < 0) continue;
    ChartStats& s = st[static_cast<size_t>(c)];
    s.page = atlas.chart_page[static_cast<size_t>(c)];
    ++s.faces;
    s.uv_area += std::abs(atlas_face_area(atlas, static_cast<int>(f)));
    add_face_moments(mesh, f, static_cast<size_t>(c), s, moments);
    add_border_sides(topo, atlas, f, c, s);
  }
  for (size_t c = 0; c < nc; ++c) fit_plane(moments, c, st[c]);
  orient_normals(mesh, atlas, st);
  return st;
}

namespace {

// Unites, across every UV-continuous pair of faces on a non-degenerate edge, the two faces (in
// faces) and their matching corners (in corners, indexed face * 3 + corner).
void unite_continuous(const TexturedMesh& mesh, const Topology& topo, UnionFind& faces, UnionFind& corners) {
  for (const Edge& e : topo.edges) {
    if (e.a == e.b) continue;
    for (int i = 0; i < e.num_faces; ++i)
      for (int j = i + 1; j < e.num_faces; ++j) {
        const EdgeIncidence& x = topo.edge_faces[static_cast<size_t>(e.first_incidence + i)];
        const EdgeIncidence& y = topo.edge_faces[static_cast<size_t>(e.first_incidence + j)];
        if (!uv_continuous(mesh, topo, x.face, x.local, y.face, y.local)) continue;
        faces.unite(x.face, y.face);
        int gk = 0, gk1 = 0;
        matching_corners(topo, x.face, x.local, y.face, y.local, gk, gk1);
        corners.unite(x.face * 3 + x.local, y.face * 3 + gk);
        corners.unite(x.face * 3 + (x.local + 1) % 3, y.face * 3 + gk1);
      }
  }
}

// Fills at (cleared before) from the face and corner classes: one chart per face class and one
// wedge per corner class, numbered in order of first face; faces without a page get no chart.
void build_atlas(const TexturedMesh& mesh, const Topology& topo, UnionFind& faces, UnionFind& corners, Atlas& at) {
  const size_t nf = mesh.faces.size();
  at.face_chart.assign(nf, -1);
  at.face_wedge.assign(nf, {-1, -1, -1});
  std::vector<int> chart_of_root(nf, -1), wedge_of_root(nf * 3, -1);
  for (size_t f = 0; f < nf; ++f) {
    if (mesh.faces[f].page == kNoPage) continue;
    const int r = faces.find(static_cast<int>(f));
    int& c = chart_of_root[static_cast<size_t>(r)];
    if (c < 0) {
      c = at.num_charts++;
      at.chart_page.push_back(mesh.faces[f].page);
    }
    at.face_chart[f] = c;
    for (int k = 0; k < 3; ++k) {
      const int cr = corners.find(static_cast<int>(f * 3 + static_cast<size_t>(k)));
      int& w = wedge_of_root[static_cast<size_t>(cr)];
      if (w < 0) {
        w = static_cast<int>(at.wedge_uv.size());
        at.wedge_uv.push_back(mesh.corner_texel(f, k));
        at.wedge_vertex.push_back(topo.face_vertex[f][static_cast<size_t>(k)]);
      }
      at.face_wedge[f][static_cast<size_t>(k)] = w;
    }
  }
}

// Collects the seams of cs.atlas (manifold edges between charted faces, UV-discontinuous) into
// one chain per chart pair, in edge order; adds their 3D lengths and counts to cs.
void collect_seam_chains(const TexturedMesh& mesh, const Topology& topo, ChartSet& cs) {
  const Atlas& at = cs.atlas;
  std::map<std::pair<int, int>, int> chain_of;
  for (size_t ei = 0; ei < topo.edges.size(); ++ei) {
    const Edge& e = topo.edges[ei];
    if (e.num_faces != 2 || e.a == e.b) continue;
    const EdgeIncidence& x = topo.edge_faces[static_cast<size_t>(e.first_incidence)];
    const EdgeIncidence& y = topo.edge_faces[static_cast<size_t>(e.first_incidence + 1)];
    const int ca = at.face_chart[static_cast<size_t>(x.face)], cb = at.face_chart[static_cast<size_t>(y.face)];
    if (ca < 0 || cb < 0) continue;
    if (uv_continuous(mesh, topo, x.face, x.local, y.face, y.local)) continue;
    const auto key = std::make_pair(std::min(ca, cb), std::max(ca, cb));
    auto it = chain_of.find(key);
    if (it == chain_of.end()) {
      it = chain_of.emplace(key, static_cast<int>(cs.chains.size())).first;
      SeamChain ch;
      ch.chart_a = key.first;
      ch.chart_b = key.second;
      cs.chains.push_back(ch);
    }
    SeamChain& ch = cs.chains[static_cast<size_t>(it->second)];
    ch.edges.push_back(static_cast<int>(ei));
    const double len = (mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.a)])] -
                        mesh.positions[static_cast<size_t>(topo.position_of_vertex[static_cast<size_t>(e.b)])]).norm();
    ch.length_3d += len;
    cs.seam_length_3d += len;
    ++cs.seam_edges;
  }
}

}  // namespace

ChartSet build_charts(const TexturedMesh& mesh, const Topology& topo) {
  const size_t nf = mesh.faces.size();
  UnionFind faces(nf), corners(nf * 3);
  unite_continuous(mesh, topo, faces, corners);
  ChartSet cs;
  build_atlas(mesh, topo, faces, corners, cs.atlas);
  cs.stats = chart_stats(mesh, topo, cs.atlas);
  for (const ChartStats& s : cs.stats) {
    if (s.uv_area == 0) ++cs.zero_area_charts;
    cs.uv_border_length += s.uv_border;
  }
  collect_seam_chains(mesh, topo, cs);
  // Each chart's chains (a chain of a chart with itself listed once).
  cs.chart_chains.assign(static_cast<size_t>(cs.atlas.num_charts), {});
  for (size_t i = 0; i < cs.chains.size(); ++i) {
    cs.chart_chains[static_cast<size_t>(cs.chains[i].chart_a)].push_back(static_cast<int>(i));
    if (cs.chains[i].chart_b != cs.chains[i].chart_a)
      cs.chart_chains[static_cast<size_t>(cs.chains[i].chart_b)].push_back(static_cast<int>(i));
  }
  return cs;
}

}  // namespace texdefrag
