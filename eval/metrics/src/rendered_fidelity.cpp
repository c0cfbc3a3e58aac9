// Rendered-view fidelity: textured orthographic software renders of input and output from fixed
// views, the texture read on a forced MIP level (as a renderer does for a distant model), compared
// by PSNR and SSIM (docs/eval.md, "Appearance"). Screen basis and framing follow the bench's
// chart renders (eval/bench/src/views.cpp): z up, orthographic, z-buffered.
#include "texdefrag/eval/appearance.h"

#include <algorithm>
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

GBuffer rasterise(const TexturedMesh& mesh, const Camera& cam) {
  GBuffer g;
  g.width = cam.width, g.height = cam.height;
  const size_t n = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  g.face.assign(n, -1);
  g.bary.assign(n, {0, 0, 0});
  std::vector<double> depth(n, -std::numeric_limits<double>::infinity());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    std::array<Vec3, 3> t;
    for (int k = 0; k < 3; ++k) {
      const Vec3& q = mesh.corner_position(f, k);
      t[static_cast<size_t>(k)] = Vec3(cam.margin + (q.dot(cam.sx) - cam.x0) * cam.scale,
                                       cam.height - cam.margin - (q.dot(cam.sy) - cam.y0) * cam.scale, q.dot(cam.toward));
    }
    const double area = (t[1].x() - t[0].x()) * (t[2].y() - t[0].y()) - (t[1].y() - t[0].y()) * (t[2].x() - t[0].x());
    if (area == 0 || !std::isfinite(area)) continue;
    const int bx0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].x(), t[1].x(), t[2].x()}))));
    const int bx1 = std::min(g.width - 1, static_cast<int>(std::ceil(std::max({t[0].x(), t[1].x(), t[2].x()}))));
    const int by0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].y(), t[1].y(), t[2].y()}))));
    const int by1 = std::min(g.height - 1, static_cast<int>(std::ceil(std::max({t[0].y(), t[1].y(), t[2].y()}))));
    for (int y = by0; y <= by1; ++y)
      for (int x = bx0; x <= bx1; ++x) {
        const double cx = x + 0.5, cy = y + 0.5;
        double w[3];
        for (int k = 0; k < 3; ++k) {
          const Vec3& a = t[static_cast<size_t>((k + 1) % 3)];
          const Vec3& b = t[static_cast<size_t>((k + 2) % 3)];
          w[k] = ((b.x() - a.x()) * (cy - a.y()) - (b.y() - a.y()) * (cx - a.x())) / area;
        }
        if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
        const double z = w[0] * t[0].z() + w[1] * t[1].z() + w[2] * t[2].z();
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(g.width) + static_cast<size_t>(x);
        if (z <= depth[i]) continue;
        depth[i] = z;
        g.face[i] = static_cast<int>(f);
        g.bary[i] = {static_cast<float>(w[0]), static_cast<float>(w[1]), static_cast<float>(w[2])};
      }
  }
  return g;
}

Image shade(const TexturedMesh& mesh, const std::vector<std::vector<Image>>& pyramids, const GBuffer& g, int level,
            std::vector<uint8_t>* mask) {
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
    const std::vector<Image>& pyr = pyramids[static_cast<size_t>(fc.page)];
    const Image& tex = pyr[static_cast<size_t>(std::min<int>(level, static_cast<int>(pyr.size()) - 1))];
    Vec2 uv(0, 0);
    for (int k = 0; k < 3; ++k) uv += static_cast<double>(g.bary[i][static_cast<size_t>(k)]) * mesh.texcoords[static_cast<size_t>(fc.vt[static_cast<size_t>(k)])];
    double rgb[3];
    bilinear_rgb(tex, uv.x() * tex.width, uv.y() * tex.height, rgb);
    for (int c = 0; c < 3; ++c) px[c] = static_cast<uint8_t>(std::lround(std::clamp(rgb[c], 0.0, 255.0)));
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
  return shade(mesh, pyramids, rasterise(mesh, frame_camera(frame, toward, size)), level, mask);
}

RenderFidelity rendered_fidelity(const TexturedMesh& in, const std::vector<Image>& in_pages, const TexturedMesh& out,
                                 const std::vector<Image>& out_pages, const RenderFidelityOptions& options) {
  if (options.views < 1 || options.size < 16 || options.max_level < 0)
    throw std::invalid_argument("rendered_fidelity: views >= 1, size >= 16 and max_level >= 0 required");
  if (in_pages.size() != in.pages.size() || out_pages.size() != out.pages.size())
    throw std::invalid_argument("rendered_fidelity: one image per page expected");
  const auto in_pyr = pyramids_of(in_pages, options.max_level);
  const auto out_pyr = pyramids_of(out_pages, options.max_level);
  RenderFidelity r;
  r.views = options.views, r.size = options.size;
  const size_t nl = static_cast<size_t>(options.max_level) + 1;
  // Per level: stacked renders of all views (one tall image each), compared once.
  std::vector<Image> in_l(nl), out_l(nl);
  Image in_ref;
  std::vector<uint8_t> mask;
  // Every view is size x size, so the views stack into one tall image per level (SSIM windows
  // meet at the 2% background margins between views).
  auto append = [](Image& dst, const Image& src) {
    dst.width = src.width, dst.channels = 3, dst.height += src.height;
    dst.pixels.insert(dst.pixels.end(), src.pixels.begin(), src.pixels.end());
  };
  for (int v = 0; v < options.views; ++v) {
    // Square renders: the framing fits inside size x size whatever the view's aspect.
    Camera cam = frame_camera(in, render_view_direction(v, options.views), options.size);
    cam.width = cam.height = options.size;
    const GBuffer gi = rasterise(in, cam), go = rasterise(out, cam);
    for (size_t l = 0; l < nl; ++l) {
      std::vector<uint8_t> mi, mo;
      const Image a = shade(in, in_pyr, gi, static_cast<int>(l), &mi);
      const Image b = shade(out, out_pyr, go, static_cast<int>(l), &mo);
      append(in_l[l], a);
      append(out_l[l], b);
      if (l == 0) {
        append(in_ref, a);
        for (size_t i = 0; i < mi.size(); ++i) mask.push_back(static_cast<uint8_t>(mi[i] | mo[i]));
      }
    }
  }
  for (size_t l = 0; l < nl; ++l) {
    RenderLevel L;
    L.level = static_cast<int>(l);
    L.pixels = static_cast<size_t>(std::count(mask.begin(), mask.end(), 1));
    L.input_psnr_db = psnr(in_l[l], in_ref, mask);
    L.input_ssim = ssim(in_l[l], in_ref, mask);
    L.output_psnr_db = psnr(out_l[l], in_ref, mask);
    L.output_ssim = ssim(out_l[l], in_ref, mask);
    L.pair_psnr_db = psnr(out_l[l], in_l[l], mask);
    L.pair_ssim = ssim(out_l[l], in_l[l], mask);
    r.levels.push_back(L);
  }
  return r;
}

}  // namespace texdefrag::eval
