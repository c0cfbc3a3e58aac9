// Views for the eval harness, after Liu et al. 2024: chart-coloured atlas pages (Figures 13-14:
// every textured face's UV triangle filled with its chart's colour) and oblique 3D renders coloured
// by chart or by detected region (Figure 11), drawn by the shared rasteriser (eval/raster).
#include "texdefrag/eval/bench.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/eval/raster.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"

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
    raster::scan_triangle({Vec3(t[0].x(), t[0].y(), 0), Vec3(t[1].x(), t[1].y(), 0), Vec3(t[2].x(), t[2].y(), 0)}, im.width,
                          im.height, [&](const raster::Fragment& fr) { put(fr.x, fr.y); });
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

namespace texdefrag::bench {

Image render_3d(const TexturedMesh& mesh, const std::vector<int>& face_colour, int size) {
  if (size < 16) throw BenchError("render_3d: size must be at least 16");
  if (face_colour.size() != mesh.faces.size()) throw BenchError("render_3d: one colour id per face expected");
  const double kPi = 3.14159265358979323846;
  const double az = 35 * kPi / 180, el = 40 * kPi / 180;
  const Vec3 toward(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));  // to the camera
  const Vec3 sx(-std::sin(az), std::cos(az), 0);
  const Vec3 sy = toward.cross(sx);  // screen up
  const Vec3 light = (toward + Vec3(0.3, -0.2, 0.6)).normalized();
  std::vector<Vec3> p(mesh.positions.size());
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (const Face& f : mesh.faces)
    for (int k = 0; k < 3; ++k) used[static_cast<size_t>(f.v[static_cast<size_t>(k)])] = 1;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec3& q = mesh.positions[i];
    p[i] = Vec3(q.dot(sx), q.dot(sy), q.dot(toward));
    if (!used[i] || !q.allFinite()) continue;
    x0 = std::min(x0, p[i].x()), x1 = std::max(x1, p[i].x());
    y0 = std::min(y0, p[i].y()), y1 = std::max(y1, p[i].y());
  }
  Image im;
  im.channels = 3;
  if (x1 < x0) {  // no face
    im.width = im.height = size;
  } else {
    const double w = std::max(x1 - x0, 1e-12), h = std::max(y1 - y0, 1e-12);
    im.width = w >= h ? size : std::max(16, static_cast<int>(std::lround(size * w / h)));
    im.height = h > w ? size : std::max(16, static_cast<int>(std::lround(size * h / w)));
  }
  im.pixels.assign(static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * 3, 245);
  if (x1 < x0) return im;
  const double margin = 0.02 * std::max(im.width, im.height);
  const double s = std::min((im.width - 2 * margin) / std::max(x1 - x0, 1e-12), (im.height - 2 * margin) / std::max(y1 - y0, 1e-12));
  raster::DepthBuffer zb(im.width, im.height);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    std::array<Vec3, 3> t;
    std::array<Vec3, 3> world;
    for (int k = 0; k < 3; ++k) {
      const size_t v = static_cast<size_t>(mesh.faces[f].v[static_cast<size_t>(k)]);
      world[static_cast<size_t>(k)] = mesh.positions[v];
      t[static_cast<size_t>(k)] = Vec3(margin + (p[v].x() - x0) * s, im.height - margin - (p[v].y() - y0) * s, p[v].z());
    }
    const Vec3 n = (world[1] - world[0]).cross(world[2] - world[0]);
    const double nn = n.norm();
    const double shade = 0.35 + 0.65 * (nn > 0 ? std::abs(n.dot(light)) / nn : 0.0);
    std::array<uint8_t, 3> base = face_colour[f] < 0 ? std::array<uint8_t, 3>{150, 150, 150} : chart_colour(face_colour[f]);
    std::array<uint8_t, 3> c;
    for (int k = 0; k < 3; ++k)
      c[static_cast<size_t>(k)] = static_cast<uint8_t>(std::lround(base[static_cast<size_t>(k)] * shade));
    zb.draw(t, [&](const raster::Fragment& fr) {
      const size_t i = static_cast<size_t>(fr.y) * static_cast<size_t>(im.width) + static_cast<size_t>(fr.x);
      std::copy(c.begin(), c.end(), &im.pixels[i * 3]);
    });
  }
  return im;
}

std::string write_chart_render(const std::string& obj_path, const std::string& png_path, int size) {
  const TexturedMesh mesh = read_obj(obj_path);
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  const fs::path folder = fs::path(png_path).parent_path();
  if (!folder.empty()) fs::create_directories(folder);
  write_image(png_path, render_3d(mesh, charts.atlas.face_chart, size), ImageFormat::Png);
  return png_path;
}

std::vector<int> detect_regions(const TexturedMesh& mesh, const std::string& config_path,
                                const std::vector<std::string>& overrides, const std::string& input_path) {
  RunOptions ro;
  ro.input = input_path;
  ro.write_output = false;
  ro.stop_after = "detector";
  Regions regions;
  ro.on_stage = [&](const std::string& section, const StageContext& ctx) {
    if (section == "detector") regions = ctx.regions;
  };
  run_pipeline(load_config(config_path, overrides), ro);
  if (regions.num_regions <= 1) return {};  // one region (no constraint) or none: nothing to colour
  if (regions.face_region.size() != mesh.faces.size())
    throw BenchError(input_path + ": the detector's regions do not match the model's " + std::to_string(mesh.faces.size()) +
                     " faces");
  return regions.face_region;
}

std::string write_region_render(const std::string& obj_path, const std::string& config_path,
                                const std::vector<std::string>& overrides, const std::string& png_path, int size) {
  const TexturedMesh mesh = read_obj(obj_path);
  const std::vector<int> regions = detect_regions(mesh, config_path, overrides, obj_path);
  if (regions.empty()) return "";
  const fs::path folder = fs::path(png_path).parent_path();
  if (!folder.empty()) fs::create_directories(folder);
  write_image(png_path, render_3d(mesh, regions, size), ImageFormat::Png);
  return png_path;
}

}  // namespace texdefrag::bench
