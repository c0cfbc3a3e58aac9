// Rendered-view fidelity: textured orthographic software renders of input and output from fixed
// views at decreasing sizes (the model seen from farther and farther away), each face's texture
// read with trilinear MIP-mapping at the level a GPU picks, compared by PSNR and SSIM with a
// prefiltered reference: the input at MIP level 0 rendered with supersampling and box-filtered
// down (docs/eval.md, "Appearance"). Screen basis follows the bench's chart renders
// (eval/bench/src/views.cpp): z up, orthographic, z-buffered by the shared rasteriser (raster.h).
#include "texdefrag/eval/appearance.h"
#include "texdefrag/eval/raster.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace texdefrag::eval {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Per pixel: the nearest face (-1 for background) and its barycentric coordinates.
struct GBuffer {
  int width = 0, height = 0;
  std::vector<int> face;
  std::vector<std::array<float, 3>> bary;
};

struct Camera {
  Vec3 sx, sy, toward;
  double x0 = 0, y0 = 0, scale = 1, margin = 0;
  int width = 0, height = 0;
};

Camera frame_camera(const TexturedMesh& frame, const Vec3& toward_in, int size) {
  Camera c;
  c.toward = toward_in.normalized();
  const Vec3 up = std::abs(c.toward.z()) > 0.999 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
  c.sx = up.cross(c.toward).normalized();
  c.sy = c.toward.cross(c.sx);
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const Face& f : frame.faces)
    for (int k = 0; k < 3; ++k) {
      const Vec3& q = frame.positions[static_cast<size_t>(f.v[static_cast<size_t>(k)])];
      if (!q.allFinite()) continue;
      x0 = std::min(x0, q.dot(c.sx)), x1 = std::max(x1, q.dot(c.sx));
      y0 = std::min(y0, q.dot(c.sy)), y1 = std::max(y1, q.dot(c.sy));
    }
  if (x1 < x0) x0 = y0 = 0, x1 = y1 = 1;
  const double w = std::max(x1 - x0, 1e-12), h = std::max(y1 - y0, 1e-12);
  c.width = w >= h ? size : std::max(16, static_cast<int>(std::lround(size * w / h)));
  c.height = h > w ? size : std::max(16, static_cast<int>(std::lround(size * h / w)));
  c.margin = 0.02 * std::max(c.width, c.height);
  c.scale = std::min((c.width - 2 * c.margin) / w, (c.height - 2 * c.margin) / h);
  c.x0 = x0, c.y0 = y0;
  return c;
}

/// A square camera of `size` pixels whose mapping is exactly proportional to `size` (margin 2% of
/// the size, the longer side of the frame's extent fills the rest), so that the pixel (x, y) of a
/// render of size S covers the f x f pixels (f x, f y)... of the render of size f S.
Camera square_camera(const TexturedMesh& frame, const Vec3& toward, int size) {
  Camera c = frame_camera(frame, toward, size);
  double x1 = -1e300, y1 = -1e300;
  for (const Face& f : frame.faces)
    for (int k = 0; k < 3; ++k) {
      const Vec3& q = frame.positions[static_cast<size_t>(f.v[static_cast<size_t>(k)])];
      if (q.allFinite()) x1 = std::max(x1, q.dot(c.sx)), y1 = std::max(y1, q.dot(c.sy));
    }
  const double extent = x1 < c.x0 ? 1.0 : std::max({x1 - c.x0, y1 - c.y0, 1e-12});
  c.width = c.height = size;
  c.margin = 0.02 * size;
  c.scale = (size - 2 * c.margin) / extent;
  return c;
}

/// Screen position (pixels, y down) and depth of a model point.
Vec3 to_screen(const Camera& cam, const Vec3& q) {
  return Vec3(cam.margin + (q.dot(cam.sx) - cam.x0) * cam.scale, cam.height - cam.margin - (q.dot(cam.sy) - cam.y0) * cam.scale,
              q.dot(cam.toward));
}

GBuffer rasterise(const TexturedMesh& mesh, const Camera& cam) {
  GBuffer g;
  g.width = cam.width, g.height = cam.height;
  const size_t n = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  g.face.assign(n, -1);
  g.bary.assign(n, {0, 0, 0});
  raster::DepthBuffer zb(g.width, g.height);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    std::array<Vec3, 3> t;
    for (int k = 0; k < 3; ++k) t[static_cast<size_t>(k)] = to_screen(cam, mesh.corner_position(f, k));
    zb.draw(t, [&](const raster::Fragment& fr) {
      const size_t i = static_cast<size_t>(fr.y) * static_cast<size_t>(g.width) + static_cast<size_t>(fr.x);
      g.face[i] = static_cast<int>(f);
      g.bary[i] = {static_cast<float>(fr.bary[0]), static_cast<float>(fr.bary[1]), static_cast<float>(fr.bary[2])};
    });
  }
  return g;
}

/// Per face, the MIP level a GPU picks for it in `cam` (OpenGL's isotropic rule; the texel map of
/// a triangle under an orthographic camera is affine, so its derivatives are constant): lambda =
/// log2 of the longer of |d(s,t)/dx| and |d(s,t)/dy|, (s,t) in texels of level 0 of its page,
/// clamped to [0, levels - 1]. 0 for untextured or degenerate faces.
std::vector<float> face_lods(const TexturedMesh& mesh, const std::vector<std::vector<Image>>& pyramids, const Camera& cam) {
  std::vector<float> lod(mesh.faces.size(), 0.0f);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& fc = mesh.faces[f];
    if (fc.page == kNoPage) continue;
    const std::vector<Image>& pyr = pyramids[static_cast<size_t>(fc.page)];
    std::array<Vec3, 3> p;
    std::array<Vec2, 3> t;
    for (int k = 0; k < 3; ++k) {
      p[static_cast<size_t>(k)] = to_screen(cam, mesh.corner_position(f, k));
      const Vec2& uv = mesh.texcoords[static_cast<size_t>(fc.vt[static_cast<size_t>(k)])];
      t[static_cast<size_t>(k)] = Vec2(uv.x() * pyr[0].width, uv.y() * pyr[0].height);
    }
    Eigen::Matrix2d P, T;
    P << p[1].x() - p[0].x(), p[2].x() - p[0].x(), p[1].y() - p[0].y(), p[2].y() - p[0].y();
    T << t[1].x() - t[0].x(), t[2].x() - t[0].x(), t[1].y() - t[0].y(), t[2].y() - t[0].y();
    const double det = P.determinant();
    if (det == 0 || !std::isfinite(det)) continue;
    const Eigen::Matrix2d J = T * P.inverse();  // columns: d(s,t)/dx, d(s,t)/dy
    const double rho = std::max(J.col(0).norm(), J.col(1).norm());
    if (!(rho > 0) || !std::isfinite(rho)) continue;
    lod[f] = static_cast<float>(std::clamp(std::log2(rho), 0.0, static_cast<double>(pyr.size() - 1)));
  }
  return lod;
}

/// How shade reads a face's texture: bilinearly on MIP level `level`; or the texel of level 0
/// holding the point (`nearest`: no filter, so it never reads a texel the triangle does not
/// cover); or, with `lods`, trilinearly at the face's level lods[face] (the two nearest levels
/// read bilinearly and blended).
struct Sampling {
  int level = 0;
  bool nearest = false;
  const std::vector<float>* lods = nullptr;
};

/// repeat: the page's addressing (repeat unless `map_Kd -clamp on`), as the resampler reads it.
void sample(const std::vector<Image>& pyr, const Vec2& uv, const Sampling& s, int face, bool repeat, uint8_t* px) {
  if (s.nearest) {
    const Image& tex = pyr[0];
    const auto index = [repeat](double v, int n) {
      const double i = std::floor(v);
      return repeat ? static_cast<int>(i - n * std::floor(i / n)) : static_cast<int>(std::clamp(i, 0.0, n - 1.0));
    };
    const int x = index(uv.x() * tex.width, tex.width);
    const int y = tex.height - 1 - index(uv.y() * tex.height, tex.height);
    for (int c = 0; c < 3; ++c) px[c] = tex.at(x, y)[tex.channels >= 3 ? c : 0];
    return;
  }
  const double lod = s.lods ? (*s.lods)[static_cast<size_t>(face)] : std::min<double>(s.level, static_cast<double>(pyr.size() - 1));
  const size_t lo = static_cast<size_t>(std::floor(lod)), hi = std::min(lo + 1, pyr.size() - 1);
  const double t = lod - static_cast<double>(lo);
  double a[3], b[3] = {0, 0, 0};
  bilinear_rgb(pyr[lo], uv.x() * pyr[lo].width, uv.y() * pyr[lo].height, a, repeat);
  if (t > 0) bilinear_rgb(pyr[hi], uv.x() * pyr[hi].width, uv.y() * pyr[hi].height, b, repeat);
  for (int c = 0; c < 3; ++c) px[c] = static_cast<uint8_t>(std::lround(std::clamp((1 - t) * a[c] + t * b[c], 0.0, 255.0)));
}

/// Each covered pixel: the nearest face's texture read as `s` says (untextured faces grey 128,
/// background black); `mask`, when given, is set to 1 where a face covers the pixel.
Image shade(const TexturedMesh& mesh, const std::vector<std::vector<Image>>& pyramids, const GBuffer& g, const Sampling& s,
            std::vector<uint8_t>* mask = nullptr) {
  Image im;
  im.width = g.width, im.height = g.height, im.channels = 3;
  im.pixels.assign(g.face.size() * 3, 0);
  if (mask) mask->assign(g.face.size(), 0);
  for (size_t i = 0; i < g.face.size(); ++i) {
    const int f = g.face[i];
    if (f < 0) continue;
    if (mask) (*mask)[i] = 1;
    const Face& fc = mesh.faces[static_cast<size_t>(f)];
    uint8_t* px = &im.pixels[i * 3];
    if (fc.page == kNoPage) {
      px[0] = px[1] = px[2] = 128;
      continue;
    }
    Vec2 uv(0, 0);
    for (int k = 0; k < 3; ++k) uv += static_cast<double>(g.bary[i][static_cast<size_t>(k)]) * mesh.texcoords[static_cast<size_t>(fc.vt[static_cast<size_t>(k)])];
    sample(pyramids[static_cast<size_t>(fc.page)], uv, s, f, !mesh.pages[static_cast<size_t>(fc.page)].clamp, px);
  }
  return im;
}

/// The reference at 1/f of `fine`'s size: each pixel the rounded mean of its f x f block; `full`
/// set to 1 where every pixel of the block is covered (cover != 0).
Image box_down(const Image& fine, const std::vector<uint8_t>& cover, int f, std::vector<uint8_t>& full) {
  Image im;
  im.width = fine.width / f, im.height = fine.height / f, im.channels = 3;
  im.pixels.assign(static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * 3, 0);
  full.assign(static_cast<size_t>(im.width) * static_cast<size_t>(im.height), 0);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      double sum[3] = {0, 0, 0};
      int covered = 0;
      for (int dy = 0; dy < f; ++dy)
        for (int dx = 0; dx < f; ++dx) {
          const size_t j = static_cast<size_t>(y * f + dy) * static_cast<size_t>(fine.width) + static_cast<size_t>(x * f + dx);
          covered += cover[j] != 0;
          for (int c = 0; c < 3; ++c) sum[c] += fine.pixels[j * 3 + static_cast<size_t>(c)];
        }
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(im.width) + static_cast<size_t>(x);
      full[i] = covered == f * f;
      for (int c = 0; c < 3; ++c) im.pixels[i * 3 + static_cast<size_t>(c)] = static_cast<uint8_t>(std::lround(sum[c] / (f * f)));
    }
  return im;
}

std::vector<std::vector<Image>> pyramids_of(const std::vector<Image>& pages, int max_level) {
  std::vector<std::vector<Image>> p;
  p.reserve(pages.size());
  for (const Image& im : pages) p.push_back(mip_pyramid(im, max_level));
  return p;
}

}  // namespace

Vec3 render_view_direction(int i, int n) {
  if (n >= 5 && i == n - 1) return Vec3(0, 0, 1);
  const int ring = n >= 5 ? n - 1 : n;
  const double az = (30.0 + 360.0 * i / ring) * kPi / 180, el = 35.0 * kPi / 180;
  return Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
}

Image render_textured(const TexturedMesh& mesh, const std::vector<std::vector<Image>>& pyramids, const TexturedMesh& frame,
                      const Vec3& toward, int size, int level, std::vector<uint8_t>* mask) {
  if (size < 16) throw std::invalid_argument("render_textured: size must be at least 16");
  if (pyramids.size() != mesh.pages.size()) throw std::invalid_argument("render_textured: one pyramid per page expected");
  Sampling s;
  s.level = level;
  return shade(mesh, pyramids, rasterise(mesh, frame_camera(frame, toward, size)), s, mask);
}

namespace {

/// Every view stacked into one tall image per distance step (views of one step share a size; SSIM
/// windows meet at the 2% background margins between views).
struct Stacks {
  std::vector<Image> in, out, ref;
  std::vector<std::vector<uint8_t>> mask;
};

void append(Image& dst, const Image& src) {
  dst.width = src.width, dst.channels = 3, dst.height += src.height;
  dst.pixels.insert(dst.pixels.end(), src.pixels.begin(), src.pixels.end());
}

/// One view: the reference rendered once at size x supersample, then each distance step.
void render_view(const TexturedMesh& in, const std::vector<std::vector<Image>>& in_pyr, const TexturedMesh& out,
                 const std::vector<std::vector<Image>>& out_pyr, const Vec3& toward, const RenderFidelityOptions& o,
                 Stacks& st) {
  const int fine_size = o.size * o.supersample;
  const GBuffer gref = rasterise(in, square_camera(in, toward, fine_size));
  std::vector<uint8_t> cover;
  Sampling nearest;
  nearest.nearest = true;
  const Image fine = shade(in, in_pyr, gref, nearest, &cover);
  for (int d = 0; d <= o.max_level; ++d) {
    const int size = o.size >> d;
    const Camera cam = square_camera(in, toward, size);
    std::vector<uint8_t> full;
    append(st.ref[static_cast<size_t>(d)], box_down(fine, cover, fine_size / size, full));
    std::vector<uint8_t>& m = st.mask[static_cast<size_t>(d)];
    m.insert(m.end(), full.begin(), full.end());
    const std::vector<float> in_lods = face_lods(in, in_pyr, cam), out_lods = face_lods(out, out_pyr, cam);
    Sampling si, so;
    si.lods = &in_lods, so.lods = &out_lods;
    append(st.in[static_cast<size_t>(d)], shade(in, in_pyr, rasterise(in, cam), si));
    append(st.out[static_cast<size_t>(d)], shade(out, out_pyr, rasterise(out, cam), so));
  }
}

}  // namespace

RenderFidelity rendered_fidelity(const TexturedMesh& in, const std::vector<Image>& in_pages, const TexturedMesh& out,
                                 const std::vector<Image>& out_pages, const RenderFidelityOptions& options) {
  if (options.views < 1 || options.max_level < 0 || options.supersample < 1 || options.max_level > 10 ||
      (options.size >> options.max_level) < 16 || options.size % (1 << options.max_level) != 0)
    throw std::invalid_argument("rendered_fidelity: views >= 1, supersample >= 1, max_level in 0..10 and a size that "
                                "is a multiple of 2^max_level with size / 2^max_level >= 16 required");
  if (in_pages.size() != in.pages.size() || out_pages.size() != out.pages.size())
    throw std::invalid_argument("rendered_fidelity: one image per page expected");
  const auto in_pyr = pyramids_of(in_pages, 64), out_pyr = pyramids_of(out_pages, 64);  // every level to 1x1
  const size_t nl = static_cast<size_t>(options.max_level) + 1;
  Stacks st{std::vector<Image>(nl), std::vector<Image>(nl), std::vector<Image>(nl), std::vector<std::vector<uint8_t>>(nl)};
  for (int v = 0; v < options.views; ++v)
    render_view(in, in_pyr, out, out_pyr, render_view_direction(v, options.views), options, st);
  RenderFidelity r;
  r.views = options.views, r.size = options.size, r.supersample = options.supersample;
  for (size_t l = 0; l < nl; ++l) {
    RenderLevel L;
    L.level = static_cast<int>(l);
    L.size = options.size >> l;
    L.pixels = static_cast<size_t>(std::count(st.mask[l].begin(), st.mask[l].end(), 1));
    L.input_psnr_db = psnr(st.in[l], st.ref[l], st.mask[l]);
    L.input_ssim = ssim(st.in[l], st.ref[l], st.mask[l]);
    L.output_psnr_db = psnr(st.out[l], st.ref[l], st.mask[l]);
    L.output_ssim = ssim(st.out[l], st.ref[l], st.mask[l]);
    L.pair_psnr_db = psnr(st.out[l], st.in[l], st.mask[l]);
    L.pair_ssim = ssim(st.out[l], st.in[l], st.mask[l]);
    r.levels.push_back(L);
  }
  return r;
}

}  // namespace texdefrag::eval
