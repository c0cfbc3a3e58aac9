// Input-vs-output comparison of ../shared/docs/METHOD.md section 3: distortion of the UV map
// (ARAP measure and symmetric Dirichlet of Liu et al. 2024, "planar feature-preserving texture
// defragmentation", and Maggiordomo et al. 2021) over faces matched by 3D triangle, and texture
// fidelity at surface samples (PSNR; fraction copied without resampling).
#include "texdefrag/core/charts.h"
#include "texdefrag/core/distortion.h"
#include "texdefrag/eval/appearance.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj.h"

#include <stdlib.h>

#include <algorithm>
#include <filesystem>
#include <cmath>
#include <map>
#include <limits>
#include <stdexcept>

namespace texdefrag::eval {
namespace {

/// The input/output UV triangles (texels of each side's page) of a matched input face, output
/// corners ordered like the input corners. False when the face is unmatched or untextured on a side.
bool matched_uvs(const TexturedMesh& in, const TexturedMesh& out, const FaceMatch& match, size_t fi,
                 Vec2 orig[3], Vec2 now[3], int& fo) {
  fo = match.output_of_input[fi];
  if (fo < 0 || in.faces[fi].page == kNoPage || out.faces[static_cast<size_t>(fo)].page == kNoPage) return false;
  for (int k = 0; k < 3; ++k) {
    orig[k] = in.corner_texel(fi, k);
    now[k] = out.corner_texel(static_cast<size_t>(fo), match.output_corner[fi][static_cast<size_t>(k)]);
  }
  return true;
}

double uv_area(const Vec2 t[3]) {
  return 0.5 * std::abs((t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x());
}

/// RGB of texel (ix, iy) (y up); grey images are replicated.
void texel_rgb(const Image& img, int ix, int iy, double rgb[3]) {
  const uint8_t* p = img.at(ix, img.height - 1 - iy);
  for (int c = 0; c < 3; ++c) rgb[c] = p[img.channels >= 3 ? c : 0];
}

/// The 8 symmetries of the texel grid: rotations by multiples of 90 degrees, then the same
/// composed with the mirror y -> -y. Row-major 2x2 (a b; c d).
constexpr double kGridSymmetry[8][4] = {{1, 0, 0, 1},  {0, -1, 1, 0},  {-1, 0, 0, -1}, {0, 1, -1, 0},
                                        {1, 0, 0, -1}, {0, 1, 1, 0},   {-1, 0, 0, 1},  {0, -1, -1, 0}};

Vec2 apply_symmetry(int r, const Vec2& p) {
  const double* m = kGridSymmetry[r];
  return {m[0] * p.x() + m[1] * p.y(), m[2] * p.x() + m[3] * p.y()};
}

/// Finds a whole-texel map (a symmetry of the texel grid and an integer translation) taking orig
/// to now within tol texels. Returns the symmetry index 0..7 (-1 when none) and the translation.
int whole_texel_map(const Vec2 orig[3], const Vec2 now[3], double tol, Vec2& t) {
  for (int r = 0; r < 8; ++r) {
    const Vec2 tr = now[0] - apply_symmetry(r, orig[0]);
    t = Vec2(std::round(tr.x()), std::round(tr.y()));
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) ok = (apply_symmetry(r, orig[k]) + t - now[k]).cwiseAbs().maxCoeff() <= tol;
    if (ok) return r;
  }
  return -1;
}

void check_images(const TexturedMesh& mesh, const std::vector<Image>& pages, const char* which) {
  if (pages.size() != mesh.pages.size())
    throw std::invalid_argument(std::string("eval: ") + which + " has " + std::to_string(mesh.pages.size()) +
                                " pages but " + std::to_string(pages.size()) + " images");
  for (size_t p = 0; p < pages.size(); ++p) {
    const Image& im = pages[p];
    if (im.width != mesh.pages[p].width || im.height != mesh.pages[p].height || im.channels < 1 ||
        im.pixels.size() != static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * static_cast<size_t>(im.channels))
      throw std::invalid_argument(std::string("eval: ") + which + " page " + std::to_string(p) + " ('" +
                                  mesh.pages[p].image_path + "'): image is " + std::to_string(im.width) + "x" +
                                  std::to_string(im.height) + ", page is " + std::to_string(mesh.pages[p].width) +
                                  "x" + std::to_string(mesh.pages[p].height));
  }
}

}  // namespace

DistortionMetrics uv_distortion(const TexturedMesh& in, const TexturedMesh& out, const FaceMatch& match) {
  // note: an output chart laid out as a mirror image of its input (with its texture mirrored
  // likewise, as MeshLab-written M-method outputs are, everywhere) shows the same texture on the
  // surface: its reflection is a convention, not distortion. The same holds for one input chart
  // welded mirrored into an output chart (texdefrag's mergers do that when the smaller chart is a
  // mirror image of its neighbour). So faces are grouped by (output chart, input chart); a group
  // whose faces reverse orientation over most of its input UV area while its output triangles turn
  // like the rest of its output chart's (area-weighted majority) is measured mirrored (y -> -y);
  // its faces whose orientation still disagrees, and the faces of a group turning against its
  // chart (a folded piece), are the flipped ones: core/distortion.h's MirrorGroups, the rule
  // atlas_distortion applies too.
  const Topology otopo = build_topology(out);
  const ChartSet ocharts = build_charts(out, otopo);
  const Topology itopo = build_topology(in);
  const ChartSet icharts = build_charts(in, itopo);
  auto out_chart = [&](int fo) { return ocharts.atlas.face_chart[static_cast<size_t>(fo)]; };
  MirrorGroups groups;
  for (size_t f = 0; f < in.faces.size(); ++f) {
    Vec2 o[3], n[3];
    int fo;
    Eigen::Matrix2d J;
    if (!matched_uvs(in, out, match, f, o, n, fo) || !uv_jacobian(o, n, J)) continue;
    groups.add(out_chart(fo), icharts.atlas.face_chart[f], uv_area(o), J, n);
  }
  DistortionMetrics d;
  DistortionSums sums;
  std::vector<char> chart_mirrored(static_cast<size_t>(ocharts.atlas.num_charts), 0);
  for (size_t f = 0; f < in.faces.size(); ++f) {
    Vec2 o[3], n[3];
    int fo;
    if (!matched_uvs(in, out, match, f, o, n, fo)) continue;
    ++d.faces;
    if (groups.mirrored(out_chart(fo), icharts.atlas.face_chart[f])) {
      chart_mirrored[static_cast<size_t>(out_chart(fo))] = 1;
      ++d.mirrored_faces;
      for (Vec2& p : n) p.y() = -p.y();
    }
    const double w = uv_area(o);
    Eigen::Matrix2d J;
    if (w == 0 || !uv_jacobian(o, n, J)) {
      ++d.zero_area_input;
      continue;
    }
    sums.add(w, J);
  }
  d.arap = sums.mean_arap();
  d.symmetric_dirichlet = sums.mean_symmetric_dirichlet();
  d.flipped = sums.flipped;
  d.weight = sums.weight;
  for (char m : chart_mirrored) d.mirrored_charts += m;
  return d;
}

FidelityMetrics texture_fidelity(const TexturedMesh& in, const std::vector<Image>& in_pages, const TexturedMesh& out,
                                 const std::vector<Image>& out_pages, const FaceMatch& match,
                                 const FidelityOptions& options) {
  if (options.max_subdivision < 1) throw std::invalid_argument("eval: max_subdivision must be >= 1");
  check_images(in, in_pages, "input");
  check_images(out, out_pages, "output");
  FidelityMetrics r;
  double total_area = 0;
  for (size_t f = 0; f < in.faces.size(); ++f) {
    Vec2 o[3], n[3];
    int fo;
    if (matched_uvs(in, out, match, f, o, n, fo)) total_area += uv_area(o);
  }
  if (total_area <= 0) return r;
  const double density = static_cast<double>(options.samples) / total_area;

  double sq = 0, copied = 0, rigid = 0, sampled = 0;
  for (size_t f = 0; f < in.faces.size(); ++f) {
    Vec2 o[3], n[3];
    int fo;
    if (!matched_uvs(in, out, match, f, o, n, fo)) continue;
    const double area = uv_area(o);
    if (area == 0) continue;
    ++r.faces;
    r.weight += area;
    const Image& ii = in_pages[static_cast<size_t>(in.faces[f].page)];
    const Image& oi = out_pages[static_cast<size_t>(out.faces[static_cast<size_t>(fo)].page)];
    // Each page read with its own addressing (repeat unless `map_Kd -clamp on`), as the resampler does.
    const bool in_repeat = !in.pages[static_cast<size_t>(in.faces[f].page)].clamp;
    const bool out_repeat = !out.pages[static_cast<size_t>(out.faces[static_cast<size_t>(fo)].page)].clamp;
    Vec2 t;
    const int rot = whole_texel_map(o, n, options.rigid_tolerance, t);
    if (rot >= 0) {
      ++r.rigid_faces;
      rigid += area;
    }
    const long m = std::clamp<long>(std::lround(std::sqrt(area * density)), 1L, options.max_subdivision);
    const double w = area / static_cast<double>(m * m);
    const double inv = 1.0 / static_cast<double>(m);
    // Stratified: the centroids of the m^2 sub-triangles of the regular subdivision.
    auto sample = [&](double a, double b) {
      const Vec2 pi = o[0] + a * (o[1] - o[0]) + b * (o[2] - o[0]);
      const Vec2 po = n[0] + a * (n[1] - n[0]) + b * (n[2] - n[0]);
      double ci[3], co[3];
      bilinear_rgb(ii, pi.x(), pi.y(), ci, in_repeat);
      bilinear_rgb(oi, po.x(), po.y(), co, out_repeat);
      double e = 0;
      for (int c = 0; c < 3; ++c) e += (ci[c] - co[c]) * (ci[c] - co[c]);
      sq += w * e / 3.0;
      sampled += w;
      ++r.samples;
      if (rot < 0) return;
      const double ix = std::floor(pi.x()), iy = std::floor(pi.y());
      if (ix < 0 || iy < 0 || ix >= ii.width || iy >= ii.height) return;
      // The texel's centre maps exactly onto an output texel centre (half-integers).
      const Vec2 q = apply_symmetry(rot, Vec2(ix + 0.5, iy + 0.5)) + t;
      const double qx = std::floor(q.x()), qy = std::floor(q.y());
      if (qx < 0 || qy < 0 || qx >= oi.width || qy >= oi.height) return;
      double ti[3], to[3];
      texel_rgb(ii, static_cast<int>(ix), static_cast<int>(iy), ti);
      texel_rgb(oi, static_cast<int>(qx), static_cast<int>(qy), to);
      if (ti[0] == to[0] && ti[1] == to[1] && ti[2] == to[2]) copied += w;
    };
    for (long i = 0; i < m; ++i)
      for (long j = 0; i + j < m; ++j) {
        sample((static_cast<double>(i) + 1.0 / 3) * inv, (static_cast<double>(j) + 1.0 / 3) * inv);
        if (i + j <= m - 2) sample((static_cast<double>(i) + 2.0 / 3) * inv, (static_cast<double>(j) + 2.0 / 3) * inv);
      }
  }
  if (sampled > 0) {
    // note: divided by the sum of sample weights (not r.weight) so that "all copied" is exactly 1.
    r.mse = sq / sampled;
    r.copied_fraction = copied / sampled;
    r.rigid_fraction = rigid / r.weight;
  }
  r.psnr_db = r.mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / r.mse) : std::numeric_limits<double>::infinity();
  return r;
}

std::vector<Image> load_pages(const TexturedMesh& mesh) {
  std::vector<Image> pages;
  pages.reserve(mesh.pages.size());
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    if (mesh.pages[p].image_path.empty())
      throw ImageError("eval: page " + std::to_string(p) + " (material '" + mesh.pages[p].material + "') has no image file");
    pages.push_back(read_image(mesh.pages[p].image_path));
  }
  return pages;
}

Comparison compare(const TexturedMesh& in_mesh, const TexturedMesh& out_mesh, const EvalOptions& options) {
  Comparison c;
  c.input = model_metrics(in_mesh);
  c.output = model_metrics(out_mesh);
  const TexturedMesh in = canonical_pages(in_mesh);
  const TexturedMesh out = canonical_pages(out_mesh);
  c.match = match_faces(in, out, options.match);
  c.distortion = uv_distortion(in, out, c.match);
  if (options.appearance) {
    c.clashes_input = texel_clashes(in, options.clash_max_level);
    c.clashes_output = texel_clashes(out, options.clash_max_level);
    c.has_clashes = true;
  }
  if (options.texture) {
    const std::vector<Image> ip = load_pages(in);
    const std::vector<Image> op = load_pages(out);
    c.fidelity = texture_fidelity(in, ip, out, op, c.match, options.fidelity);
    c.has_fidelity = true;
    if (options.appearance) {
      c.seam_colour_input = seam_colour(in, ip, options.clash_max_level);
      c.seam_colour_output = seam_colour(out, op, options.clash_max_level);
      c.has_seam_colour = true;
      c.rendered = rendered_fidelity(in, ip, out, op, options.render);
      c.has_rendered = true;
    }
  }
  return c;
}

namespace {

/// A scratch folder removed with everything in it when the guard goes.
struct ScratchDir {
  std::string path;
  ScratchDir() {
    std::string templ = (std::filesystem::temp_directory_path() / "texdefrag-eval-XXXXXX").string();
    if (!mkdtemp(templ.data())) throw ImageError("eval: cannot create a scratch folder under " + templ);
    path = templ;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

/// Reads a model of any built-in format (io/model_format.h: OBJ, OSGB, glTF/GLB). Pages embedded
/// in the model (OSGB, GLB) are written as PNG files (lossless) into `scratch` and the pages point
/// at them, so every measure reads them as it reads an OBJ's page files.
TexturedMesh read_model(const std::string& path, ScratchDir& scratch, const char* tag) {
  LoadedModel m = format_for_input(path).read(path);
  for (size_t p = 0; p < m.mesh.pages.size(); ++p) {
    if (m.page_images.size() <= p || m.page_images[p].pixels.empty()) continue;
    const std::string file = scratch.path + "/" + tag + "_page" + std::to_string(p) + ".png";
    write_image(file, m.page_images[p], ImageFormat::Png);
    m.mesh.pages[p].image_path = file;
  }
  return std::move(m.mesh);
}

}  // namespace

Comparison compare_files(const std::string& in_path, const std::string& out_path, const EvalOptions& options) {
  ScratchDir scratch;
  const TexturedMesh in = read_model(in_path, scratch, "in");
  const TexturedMesh out = read_model(out_path, scratch, "out");
  Comparison c = compare(in, out, options);
  c.input_path = in_path;
  c.output_path = out_path;
  return c;
}

}  // namespace texdefrag::eval
