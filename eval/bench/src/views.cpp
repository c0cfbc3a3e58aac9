// Chart-coloured views of atlas pages (as the atlases of Liu et al. 2024, Figures 13-14): every
// textured face's UV triangle filled with its chart's colour, so fragmentation is visible at a glance.
#include "texdefrag/eval/bench.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace fs = std::filesystem;

namespace texdefrag::bench {

std::array<uint8_t, 3> chart_colour(int chart) {
  // Golden-ratio hue steps, two saturation/value levels: neighbours in id get distant colours.
  const double h = std::fmod(0.1 + 0.6180339887498949 * chart, 1.0) * 6.0;
  const double s = (chart / 7) % 2 ? 0.55 : 0.85, v = (chart / 3) % 2 ? 0.75 : 0.95;
  const int i = static_cast<int>(h) % 6;
  const double f = h - std::floor(h), p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (i) {
    case 0: r = v, g = t, b = p; break;
    case 1: r = q, g = v, b = p; break;
    case 2: r = p, g = v, b = t; break;
    case 3: r = p, g = q, b = v; break;
    case 4: r = t, g = p, b = v; break;
    default: r = v, g = p, b = q; break;
  }
  auto c = [](double x) { return static_cast<uint8_t>(std::lround(255 * std::clamp(x, 0.0, 1.0))); };
  return {c(r), c(g), c(b)};
}

std::vector<std::string> write_chart_views(const std::string& obj_path, const std::string& prefix, int max_size) {
  if (max_size < 16) throw BenchError("write_chart_views: max_size must be at least 16");
  const TexturedMesh mesh = eval::canonical_pages(read_obj(obj_path));
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  const std::vector<int>& face_chart = charts.atlas.face_chart;

  std::vector<Image> views(mesh.pages.size());
  std::vector<double> scale(mesh.pages.size(), 1.0);
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    const Page& pg = mesh.pages[p];
    if (pg.width <= 0 || pg.height <= 0) throw BenchError(obj_path + ": page " + std::to_string(p) + " has no known size");
    scale[p] = std::min(1.0, static_cast<double>(max_size) / std::max(pg.width, pg.height));
    Image& im = views[p];
    im.width = std::max(1, static_cast<int>(std::lround(pg.width * scale[p])));
    im.height = std::max(1, static_cast<int>(std::lround(pg.height * scale[p])));
    im.channels = 3;
    im.pixels.assign(static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * 3, 40);
  }
  std::vector<uint8_t> used(mesh.pages.size(), 0);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const int page = mesh.faces[f].page;
    if (page == kNoPage || face_chart[f] < 0) continue;
    used[static_cast<size_t>(page)] = 1;
    Image& im = views[static_cast<size_t>(page)];
    const double s = scale[static_cast<size_t>(page)];
    // Pixel coordinates: x right, y down (row 0 at the top of the page).
    std::array<Vec2, 3> t;
    for (int k = 0; k < 3; ++k) {
      const Vec2 uv = mesh.corner_texel(f, k);
      t[static_cast<size_t>(k)] = Vec2(uv.x() * s, im.height - uv.y() * s);
    }
    const auto colour = chart_colour(face_chart[f]);
    auto put = [&](int x, int y) {
      if (x < 0 || y < 0 || x >= im.width || y >= im.height) return;
      uint8_t* px = &im.pixels[(static_cast<size_t>(y) * static_cast<size_t>(im.width) + static_cast<size_t>(x)) * 3];
      std::copy(colour.begin(), colour.end(), px);
    };
    const double area = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x();
    const int x0 = static_cast<int>(std::floor(std::min({t[0].x(), t[1].x(), t[2].x()})));
    const int x1 = static_cast<int>(std::ceil(std::max({t[0].x(), t[1].x(), t[2].x()})));
    const int y0 = static_cast<int>(std::floor(std::min({t[0].y(), t[1].y(), t[2].y()})));
    const int y1 = static_cast<int>(std::ceil(std::max({t[0].y(), t[1].y(), t[2].y()})));
    if (area != 0 && std::isfinite(area)) {
      for (int y = std::max(y0, 0); y <= std::min(y1, im.height - 1); ++y)
        for (int x = std::max(x0, 0); x <= std::min(x1, im.width - 1); ++x) {
          const Vec2 c(x + 0.5, y + 0.5);
          double w[3];
          for (int k = 0; k < 3; ++k) {
            const Vec2& a = t[static_cast<size_t>((k + 1) % 3)];
            const Vec2& b = t[static_cast<size_t>((k + 2) % 3)];
            w[k] = ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x()) / area;
          }
          if (w[0] >= 0 && w[1] >= 0 && w[2] >= 0) put(x, y);
        }
    }
    // Triangles smaller than a pixel stay visible: the pixel of their centroid.
    const Vec2 g = (t[0] + t[1] + t[2]) / 3.0;
    if (std::isfinite(g.x()) && std::isfinite(g.y()))
      put(static_cast<int>(std::floor(g.x())), static_cast<int>(std::floor(g.y())));
  }
  std::vector<std::string> written;
  const fs::path folder = fs::path(prefix).parent_path();
  if (!folder.empty()) fs::create_directories(folder);
  for (size_t p = 0; p < views.size(); ++p) {
    if (!used[p]) continue;
    const std::string path = prefix + "_page" + std::to_string(p) + ".png";
    write_image(path, views[p], ImageFormat::Png);
    written.push_back(path);
  }
  return written;
}

}  // namespace texdefrag::bench
