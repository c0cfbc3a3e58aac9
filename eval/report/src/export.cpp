// Report data: a model view's geometry and textures as JavaScript files for the viewer (chunks of
// faces, textures as JPEG data URLs), and atlas page images with chart outlines.
#include "export.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/bench.h"
#include "texdefrag/io/image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

namespace fs = std::filesystem;

namespace texdefrag::report {

std::string base64(const void* data, size_t n) {
  static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const uint8_t*>(data);
  std::string s;
  s.reserve((n + 2) / 3 * 4);
  for (size_t i = 0; i < n; i += 3) {
    const uint32_t v = (static_cast<uint32_t>(p[i]) << 16) | (i + 1 < n ? static_cast<uint32_t>(p[i + 1]) << 8 : 0u) |
                       (i + 2 < n ? static_cast<uint32_t>(p[i + 2]) : 0u);
    s += tbl[(v >> 18) & 63];
    s += tbl[(v >> 12) & 63];
    s += i + 1 < n ? tbl[(v >> 6) & 63] : '=';
    s += i + 2 < n ? tbl[v & 63] : '=';
  }
  return s;
}

void write_text(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    if (!f) throw ReportError(tmp + ": cannot write");
  }
  fs::rename(tmp, path);
}

Image downscale(const Image& im, int max_side) {
  const int side = std::max(im.width, im.height);
  if (side <= max_side) return im;
  const double s = static_cast<double>(max_side) / side;
  Image out;
  out.width = std::max(1, static_cast<int>(std::lround(im.width * s)));
  out.height = std::max(1, static_cast<int>(std::lround(im.height * s)));
  out.channels = 3;
  out.pixels.resize(static_cast<size_t>(out.width) * static_cast<size_t>(out.height) * 3);
  // Area average over the source texels each output pixel covers.
  for (int y = 0; y < out.height; ++y) {
    const int y0 = y * im.height / out.height, y1 = std::max(y0 + 1, (y + 1) * im.height / out.height);
    for (int x = 0; x < out.width; ++x) {
      const int x0 = x * im.width / out.width, x1 = std::max(x0 + 1, (x + 1) * im.width / out.width);
      double acc[3] = {0, 0, 0};
      for (int sy = y0; sy < y1; ++sy)
        for (int sx = x0; sx < x1; ++sx) {
          const uint8_t* p = im.at(sx, sy);
          for (int c = 0; c < 3; ++c) acc[c] += p[im.channels >= 3 ? c : 0];
        }
      const double n = static_cast<double>((y1 - y0) * (x1 - x0));
      for (int c = 0; c < 3; ++c) out.at(x, y)[c] = static_cast<uint8_t>(std::lround(acc[c] / n));
    }
  }
  return out;
}

namespace {

/// RGB copy of an image (grey replicated, alpha dropped).
Image to_rgb(const Image& im) {
  if (im.channels == 3) return im;
  Image out;
  out.width = im.width, out.height = im.height, out.channels = 3;
  out.pixels.resize(static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * 3);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y)[c] = im.at(x, y)[im.channels >= 3 ? c : 0];
  return out;
}

std::string jpeg_data_url(const Image& im, const std::string& scratch) {
  write_image(scratch, im, ImageFormat::Jpeg, 88);
  std::ifstream f(scratch, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  f.close();
  fs::remove(scratch);
  return "data:image/jpeg;base64," + base64(bytes.data(), bytes.size());
}

template <class T>
std::string b64(const std::vector<T>& v) {
  return base64(v.data(), v.size() * sizeof(T));
}

}  // namespace

ViewStats export_view(const ViewData& v, const ExportOptions& o) {
  const TexturedMesh& mesh = *v.mesh;
  ViewStats st;
  st.faces = mesh.faces.size();
  st.pages = mesh.pages.size();
  if (st.faces > o.max_faces) {
    st.too_large = true;
    return st;
  }
  fs::create_directories(o.data_dir);
  // Textures: one JS file per page, so that the page can show geometry before every image arrived.
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    const Image im = downscale(to_rgb(read_image(mesh.pages[p].image_path)), o.texture_max);
    const std::string name = v.key + "_t" + std::to_string(p) + ".js";
    const std::string js = "TD.texture(" + json(v.key).dump() + "," + std::to_string(p) + "," +
                           json(jpeg_data_url(im, (fs::path(o.data_dir) / (v.key + "_scratch.jpg")).string())).dump() + ");\n";
    write_text((fs::path(o.data_dir) / name).string(), js);
    st.bytes += js.size();
  }
  // Faces sorted by page (untextured last), cut into chunks.
  std::vector<size_t> order(mesh.faces.size());
  std::iota(order.begin(), order.end(), size_t{0});
  auto page_key = [&](size_t f) { return mesh.faces[f].page == kNoPage ? 1 << 30 : mesh.faces[f].page; };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return page_key(a) < page_key(b); });
  const size_t chunk = std::max<size_t>(1, o.chunk_faces);
  for (size_t first = 0; first < order.size() || (first == 0 && order.empty()); first += chunk) {
    const size_t last = std::min(order.size(), first + chunk);
    std::vector<float> pos, uv;
    std::vector<int32_t> chart, region;
    json groups = json::array();
    for (size_t i = first; i < last; ++i) {
      const size_t f = order[i];
      const int page = mesh.faces[f].page;
      if (groups.empty() || groups.back()[0].get<int>() != page) groups.push_back({page, i - first, 0});
      groups.back()[2] = groups.back()[2].get<size_t>() + 1;
      for (int k = 0; k < 3; ++k) {
        const Vec3 q = mesh.corner_position(f, k) - o.centre;
        pos.insert(pos.end(), {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())});
        const int vt = mesh.faces[f].vt[static_cast<size_t>(k)];
        const Vec2 t = page != kNoPage && vt >= 0 ? mesh.texcoords[static_cast<size_t>(vt)] : Vec2(0, 0);
        uv.insert(uv.end(), {static_cast<float>(t.x()), static_cast<float>(t.y())});
      }
      chart.push_back(v.face_chart[f]);
      if (!v.face_region.empty()) region.push_back(v.face_region[f]);
    }
    json d = {{"faces", last - first}, {"groups", groups}, {"p", b64(pos)}, {"u", b64(uv)}, {"c", b64(chart)}};
    if (!region.empty()) d["r"] = b64(region);
    const std::string js = "TD.chunk(" + json(v.key).dump() + "," + std::to_string(st.chunks) + "," + d.dump() + ");\n";
    write_text((fs::path(o.data_dir) / (v.key + "_g" + std::to_string(st.chunks) + ".js")).string(), js);
    st.bytes += js.size();
    ++st.chunks;
    if (order.empty()) break;
  }
  return st;
}

std::vector<std::string> write_atlas_pages(const TexturedMesh& mesh, const std::vector<int>& face_chart,
                                           const std::string& prefix, int max_side) {
  const Topology topo = build_topology(mesh);
  std::vector<std::string> written;
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    Image im = downscale(to_rgb(read_image(mesh.pages[p].image_path)), max_side);
    const double sx = static_cast<double>(im.width) / mesh.pages[p].width, sy = static_cast<double>(im.height) / mesh.pages[p].height;
    bool any = false;
    auto plot = [&](double x, double y) {
      const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(im.height - y));
      if (ix < 0 || iy < 0 || ix >= im.width || iy >= im.height) return;
      uint8_t* px = im.at(ix, iy);
      px[0] = 255, px[1] = 230, px[2] = 0;
    };
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
      if (mesh.faces[f].page != static_cast<int>(p)) continue;
      any = true;
      for (int k = 0; k < 3; ++k) {
        // A chart border: no UV-continuous face across (boundary, seam, other chart).
        const EdgeIncidence* across = topo.opposite(static_cast<int>(f), k);
        if (across && face_chart[static_cast<size_t>(across->face)] == face_chart[f] &&
            uv_continuous(mesh, topo, static_cast<int>(f), k, across->face, across->local))
          continue;
        const Vec2 a = mesh.corner_texel(f, k), b = mesh.corner_texel(f, (k + 1) % 3);
        const double ax = a.x() * sx, ay = a.y() * sy, bx = b.x() * sx, by = b.y() * sy;
        const double len = std::max(std::abs(bx - ax), std::abs(by - ay));
        if (!std::isfinite(len)) continue;
        const int n = std::max(1, static_cast<int>(std::ceil(len * 2)));
        for (int i = 0; i <= n; ++i) plot(ax + (bx - ax) * i / n, ay + (by - ay) * i / n);
      }
    }
    if (!any) continue;
    const std::string path = prefix + "_page" + std::to_string(p) + ".png";
    write_image(path, im, ImageFormat::Png);
    written.push_back(path);
  }
  return written;
}

}  // namespace texdefrag::report
