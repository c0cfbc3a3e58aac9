#include "texdefrag/core/distortion.h"

#include "texdefrag/core/topology.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <map>
#include <utility>
#include <limits>

namespace texdefrag {

bool uv_jacobian(const Vec2 orig[3], const Vec2 now[3], Eigen::Matrix2d& J) {
  Eigen::Matrix2d A, B;
  A.col(0) = orig[1] - orig[0];
  A.col(1) = orig[2] - orig[0];
  B.col(0) = now[1] - now[0];
  B.col(1) = now[2] - now[0];
  const double d = A.determinant();
  if (d == 0.0 || !std::isfinite(d)) return false;
  J = B * A.inverse();
  return true;
}

Eigen::Vector2d signed_singular_values(const Eigen::Matrix2d& J) {
  Eigen::JacobiSVD<Eigen::Matrix2d> svd(J);
  Eigen::Vector2d s = svd.singularValues();
  if (J.determinant() < 0) s.y() = -s.y();
  return s;
}

double arap_error(const Eigen::Matrix2d& J) {
  const Eigen::Vector2d s = signed_singular_values(J);
  return (s.x() - 1) * (s.x() - 1) + (s.y() - 1) * (s.y() - 1);
}

double symmetric_dirichlet(const Eigen::Matrix2d& J) {
  if (J.determinant() <= 0) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d s = signed_singular_values(J);
  return s.x() * s.x() + s.y() * s.y() + 1 / (s.x() * s.x()) + 1 / (s.y() * s.y());
}

namespace {

/// Input and output UV triangles of face f (texels); false when the face is untextured.
bool face_uvs(const TexturedMesh& mesh, const Atlas& atlas, size_t f, Vec2 o[3], Vec2 n[3]) {
  if (mesh.faces[f].page == kNoPage || atlas.face_wedge[f][0] < 0) return false;
  for (int k = 0; k < 3; ++k) {
    o[k] = mesh.corner_texel(f, k);
    n[k] = atlas.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][static_cast<size_t>(k)])];
  }
  return true;
}

double tri_area(const Vec2 o[3]) {
  return 0.5 * std::abs((o[1] - o[0]).x() * (o[2] - o[0]).y() - (o[1] - o[0]).y() * (o[2] - o[0]).x());
}

}  // namespace

DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas, const std::vector<int>& input_face_chart) {
  if (input_face_chart.size() != mesh.faces.size()) return atlas_distortion(mesh, atlas);
  // Per group (output chart, input chart): area-weighted sign of det J, and of the output UV
  // triangles' turn (corner order); per output chart: the latter over all its faces.
  std::map<std::pair<int, int>, std::pair<double, double>> group_sign;
  std::map<int, double> chart_turn;
  auto group = [&](size_t f) { return std::make_pair(atlas.face_chart[f], input_face_chart[f]); };
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec2 o[3], n[3];
    Eigen::Matrix2d J;
    if (!face_uvs(mesh, atlas, f, o, n) || !uv_jacobian(o, n, J)) continue;
    const double det = J.determinant(), w = tri_area(o);
    const double turn = (n[1] - n[0]).x() * (n[2] - n[0]).y() - (n[1] - n[0]).y() * (n[2] - n[0]).x();
    auto& g = group_sign[group(f)];
    g.first += w * ((det > 0) - (det < 0));
    g.second += w * ((turn > 0) - (turn < 0));
    chart_turn[atlas.face_chart[f]] += w * ((turn > 0) - (turn < 0));
  }
  // A group is mirrored when most of it reverses its input's orientation while it turns like the
  // rest of its output chart (a reflected, consistently welded chart); a group that turns against
  // its chart (a folded face or piece) is not, and its faces count as flipped.
  auto mirrored_group = [&](size_t f) {
    auto it = group_sign.find(group(f));
    if (it == group_sign.end() || !(it->second.first < 0)) return false;
    const double ct = chart_turn[atlas.face_chart[f]];
    return (it->second.second > 0) == (ct > 0) && it->second.second != 0 && ct != 0;
  };
  DistortionSummary r;
  double wsd = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec2 o[3], n[3];
    if (!face_uvs(mesh, atlas, f, o, n)) continue;
    const double w = tri_area(o);
    Eigen::Matrix2d J;
    if (w == 0 || !uv_jacobian(o, n, J)) {
      ++r.zero_area_input;
      continue;
    }
    if (mirrored_group(f)) {
      ++r.mirrored;
      J.row(1) = -J.row(1);  // measured through the mirror y -> -y
    }
    const double det = J.determinant();
    if (det <= 0) ++r.flipped;
    r.arap += w * arap_error(J);
    r.weight += w;
    if (det > 0) {
      r.symmetric_dirichlet += w * symmetric_dirichlet(J);
      wsd += w;
    }
  }
  if (r.weight > 0) r.arap /= r.weight;
  if (wsd > 0) r.symmetric_dirichlet /= wsd;
  return r;
}

DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas) {
  const Topology topo = build_topology(mesh);
  const ChartSet in = build_charts(mesh, topo);
  return atlas_distortion(mesh, atlas, in.atlas.face_chart);
}

}  // namespace texdefrag
