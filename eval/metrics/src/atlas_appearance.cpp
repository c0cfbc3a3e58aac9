// Atlas measures under MIP-mapping and across seams (docs/eval.md, "Appearance"): texel clashes
// per MIP level (TexMetro's "texel clashes": a MIP texel whose box-filter footprint mixes two
// charts, or a chart and gutter, bleeds one into the other when the texture is minified) and the
// colour discrepancy across 3D seams.
#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/appearance.h"
#include "texdefrag/eval/raster.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace texdefrag::eval {
namespace {

constexpr int kGutter = -1;  // no chart covers the texel (or its footprint)
constexpr int kMixed = -2;   // two charts, or a chart and gutter

/// Level-0 owner map of one page: chart of the triangle containing each texel centre.
struct OwnerMap {
  int width = 0, height = 0;
  std::vector<int> owner;  // image rows (row 0 at the top, v = 1), so MIP blocks align with the image's
};

/// Marks the texels whose centres triangle `t` (level-0 texel coordinates, y up) covers with
/// `chart` (top-left rule of the shared rasteriser, so a texel on an edge shared by two triangles
/// belongs to one of them).
void rasterise_chart_triangle(OwnerMap& m, const std::array<Vec2, 3>& t, int chart) {
  const std::array<Vec3, 3> t3 = {Vec3(t[0].x(), t[0].y(), 0), Vec3(t[1].x(), t[1].y(), 0), Vec3(t[2].x(), t[2].y(), 0)};
  raster::scan_triangle(t3, m.width, m.height, [&](const raster::Fragment& fr) {
    int& o = m.owner[static_cast<size_t>(m.height - 1 - fr.y) * static_cast<size_t>(m.width) + static_cast<size_t>(fr.x)];
    if (o == kGutter) o = chart;
    else if (o != chart) o = kMixed;
  });
}

/// The next MIP level's footprint states: a texel is uniform when its (up to) 2x2 children are.
OwnerMap coarser(const OwnerMap& a) {
  OwnerMap b;
  b.width = (a.width + 1) / 2, b.height = (a.height + 1) / 2;
  b.owner.assign(static_cast<size_t>(b.width) * static_cast<size_t>(b.height), kGutter);
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      int v = a.owner[static_cast<size_t>(2 * y) * static_cast<size_t>(a.width) + static_cast<size_t>(2 * x)];
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int sx = 2 * x + dx, sy = 2 * y + dy;
          if (sx >= a.width || sy >= a.height) continue;
          const int w = a.owner[static_cast<size_t>(sy) * static_cast<size_t>(a.width) + static_cast<size_t>(sx)];
          if (w != v) v = kMixed;
        }
      b.owner[static_cast<size_t>(y) * static_cast<size_t>(b.width) + static_cast<size_t>(x)] = v;
    }
  return b;
}

void count_level(const OwnerMap& m, ClashLevel& l) {
  l.texels += m.owner.size();
  for (int o : m.owner) {
    if (o != kGutter) ++l.used;
    if (o == kMixed) ++l.clashes;
  }
}

}  // namespace

std::vector<ClashLevel> texel_clashes(const TexturedMesh& mesh, int max_level) {
  if (max_level < 0) throw std::invalid_argument("texel_clashes: max_level must be >= 0");
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  std::vector<ClashLevel> levels(static_cast<size_t>(max_level) + 1);
  for (int l = 0; l <= max_level; ++l) levels[static_cast<size_t>(l)].level = l;
  std::vector<std::vector<size_t>> faces_of_page(mesh.pages.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    if (mesh.faces[f].page != kNoPage) faces_of_page[static_cast<size_t>(mesh.faces[f].page)].push_back(f);
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    if (faces_of_page[p].empty()) continue;
    const Page& pg = mesh.pages[p];
    if (pg.width <= 0 || pg.height <= 0)
      throw std::invalid_argument("texel_clashes: page " + std::to_string(p) + " ('" + pg.image_path + "') has no known size");
    OwnerMap m;
    m.width = pg.width, m.height = pg.height;
    m.owner.assign(static_cast<size_t>(m.width) * static_cast<size_t>(m.height), kGutter);
    for (size_t f : faces_of_page[p])
      rasterise_chart_triangle(m, {mesh.corner_texel(f, 0), mesh.corner_texel(f, 1), mesh.corner_texel(f, 2)},
                               charts.atlas.face_chart[f]);
    for (int l = 0; l <= max_level; ++l) {
      if (l > 0) m = coarser(m);
      count_level(m, levels[static_cast<size_t>(l)]);
    }
  }
  for (ClashLevel& l : levels)
    l.fraction = l.used ? static_cast<double>(l.clashes) / static_cast<double>(l.used) : 0.0;
  return levels;
}

namespace {

/// One seam edge's sample points: texel coordinates (level 0) of both sides, their pages, weight.
struct SeamSamples {
  Vec2 f0, f1, g0, g1;  // the edge on face f's and face g's page, level-0 texels
  int fpage = 0, gpage = 0;
  int n = 1;            // points t = (i + 0.5) / n
  double weight = 0;    // per point: 3D length / n
};

/// The seam edges of `mesh` (manifold, both faces textured and non-degenerate, not UV-continuous).
std::vector<SeamSamples> seam_edges(const TexturedMesh& mesh, double& length_3d) {
  const Topology topo = build_topology(mesh);
  std::vector<SeamSamples> seams;
  length_3d = 0;
  for (const Edge& e : topo.edges) {
    if (e.num_faces != 2) continue;
    const EdgeIncidence& x = topo.edge_faces[static_cast<size_t>(e.first_incidence)];
    const EdgeIncidence& y = topo.edge_faces[static_cast<size_t>(e.first_incidence) + 1];
    const size_t f = static_cast<size_t>(x.face), g = static_cast<size_t>(y.face);
    if (mesh.faces[f].page == kNoPage || mesh.faces[g].page == kNoPage) continue;
    if (topo.face_degenerate[f] || topo.face_degenerate[g]) continue;
    if (uv_continuous(mesh, topo, x.face, x.local, y.face, y.local)) continue;
    // Corners of both faces at the edge's welded vertices a and b.
    auto corner_at = [&](size_t face, int vertex) {
      for (int k = 0; k < 3; ++k)
        if (topo.face_vertex[face][static_cast<size_t>(k)] == vertex) return k;
      return -1;
    };
    const int fa = corner_at(f, e.a), fb = corner_at(f, e.b), ga = corner_at(g, e.a), gb = corner_at(g, e.b);
    if (fa < 0 || fb < 0 || ga < 0 || gb < 0) continue;
    SeamSamples s;
    s.f0 = mesh.corner_texel(f, fa), s.f1 = mesh.corner_texel(f, fb);
    s.g0 = mesh.corner_texel(g, ga), s.g1 = mesh.corner_texel(g, gb);
    s.fpage = mesh.faces[f].page, s.gpage = mesh.faces[g].page;
    const double len3 = (mesh.corner_position(f, fa) - mesh.corner_position(f, fb)).norm();
    const double texels = std::max((s.f1 - s.f0).norm(), (s.g1 - s.g0).norm());
    s.n = std::isfinite(texels) ? std::clamp(static_cast<int>(std::ceil(texels)), 1, 64) : 1;
    s.weight = len3 / s.n;
    length_3d += len3;
    seams.push_back(s);
  }
  return seams;
}

/// Bilinear colour at level-0 texel coordinates `p` read on `level` of `pyr` (clamped to its
/// coarsest level).
void read_level(const std::vector<Image>& pyr, int level, const Vec2& p, double rgb[3]) {
  const Image& base = pyr[0];
  const Image& im = pyr[std::min(static_cast<size_t>(level), pyr.size() - 1)];
  if (&im == &base) return bilinear_rgb(base, p.x(), p.y(), rgb);
  bilinear_rgb(im, p.x() * im.width / base.width, p.y() * im.height / base.height, rgb);
}

}  // namespace

SeamColourMetrics seam_colour(const TexturedMesh& mesh, const std::vector<Image>& pages, int max_level) {
  if (pages.size() != mesh.pages.size()) throw std::invalid_argument("seam_colour: one image per page expected");
  if (max_level < 0) throw std::invalid_argument("seam_colour: max_level must be >= 0");
  SeamColourMetrics r;
  const std::vector<SeamSamples> seams = seam_edges(mesh, r.length_3d);
  r.seam_edges = seams.size();
  std::vector<std::vector<Image>> pyramids(pages.size());
  for (const SeamSamples& s : seams)
    for (int p : {s.fpage, s.gpage})
      if (pyramids[static_cast<size_t>(p)].empty()) pyramids[static_cast<size_t>(p)] = mip_pyramid(pages[static_cast<size_t>(p)], max_level);
  for (int level = 0; level <= max_level; ++level) {
    SeamColourLevel L;
    L.level = level;
    double weight = 0, sum = 0, sq = 0;
    size_t samples = 0;
    for (const SeamSamples& s : seams)
      for (int i = 0; i < s.n; ++i) {
        const double t = (i + 0.5) / s.n;
        double ca[3], cb[3];
        read_level(pyramids[static_cast<size_t>(s.fpage)], level, s.f0 + t * (s.f1 - s.f0), ca);
        read_level(pyramids[static_cast<size_t>(s.gpage)], level, s.g0 + t * (s.g1 - s.g0), cb);
        const double d = std::sqrt((ca[0] - cb[0]) * (ca[0] - cb[0]) + (ca[1] - cb[1]) * (ca[1] - cb[1]) +
                                   (ca[2] - cb[2]) * (ca[2] - cb[2]));
        weight += s.weight, sum += s.weight * d, sq += s.weight * d * d;
        L.max = std::max(L.max, d);
        ++samples;
      }
    if (weight > 0) L.mean = sum / weight, L.rms = std::sqrt(sq / weight);
    r.samples = samples;
    r.levels.push_back(L);
  }
  r.mean = r.levels[0].mean, r.rms = r.levels[0].rms, r.max = r.levels[0].max;
  return r;
}

}  // namespace texdefrag::eval
