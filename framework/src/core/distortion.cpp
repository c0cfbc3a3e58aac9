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

namespace {
int sign(double x) { return (x > 0) - (x < 0); }
}  // namespace

void MirrorGroups::add(int out_chart, int in_chart, double w, const Eigen::Matrix2d& J, const Vec2 now[3]) {
  const double turn = (now[1] - now[0]).x() * (now[2] - now[0]).y() - (now[1] - now[0]).y() * (now[2] - now[0]).x();
  auto& g = group_sign_[{out_chart, in_chart}];
  g.first += w * sign(J.determinant());
  g.second += w * sign(turn);
  chart_turn_[out_chart] += w * sign(turn);
}

bool MirrorGroups::mirrored(int out_chart, int in_chart) const {
  // A group that turns against its chart (a folded face or piece) is not mirrored: its faces
  // count as flipped.
  auto it = group_sign_.find({out_chart, in_chart});
  if (it == group_sign_.end() || !(it->second.first < 0)) return false;
  auto ct = chart_turn_.find(out_chart);
  const double turn = ct == chart_turn_.end() ? 0.0 : ct->second;
  return (it->second.second > 0) == (turn > 0) && it->second.second != 0 && turn != 0;
}

void DistortionSums::add(double w, const Eigen::Matrix2d& J) {
  const double det = J.determinant();
  if (det <= 0) ++flipped;
  arap += w * arap_error(J);
  weight += w;
  if (det > 0) {
    symmetric_dirichlet += w * texdefrag::symmetric_dirichlet(J);
    symmetric_dirichlet_weight += w;
  }
}

DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas, const std::vector<int>& input_face_chart) {
  if (input_face_chart.size() != mesh.faces.size()) return atlas_distortion(mesh, atlas);
  MirrorGroups groups;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec2 o[3], n[3];
    Eigen::Matrix2d J;
    if (!face_uvs(mesh, atlas, f, o, n) || !uv_jacobian(o, n, J)) continue;
    groups.add(atlas.face_chart[f], input_face_chart[f], tri_area(o), J, n);
  }
  DistortionSummary r;
  DistortionSums sums;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec2 o[3], n[3];
    if (!face_uvs(mesh, atlas, f, o, n)) continue;
    const double w = tri_area(o);
    Eigen::Matrix2d J;
    if (w == 0 || !uv_jacobian(o, n, J)) {
      ++r.zero_area_input;
      continue;
    }
    if (groups.mirrored(atlas.face_chart[f], input_face_chart[f])) {
      ++r.mirrored;
      J.row(1) = -J.row(1);  // measured through the mirror y -> -y
    }
    sums.add(w, J);
  }
  r.arap = sums.mean_arap();
  r.symmetric_dirichlet = sums.mean_symmetric_dirichlet();
  r.flipped = sums.flipped;
  r.weight = sums.weight;
  return r;
}

DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas) {
  const Topology topo = build_topology(mesh);
  const ChartSet in = build_charts(mesh, topo);
  return atlas_distortion(mesh, atlas, in.atlas.face_chart);
}

}  // namespace texdefrag
