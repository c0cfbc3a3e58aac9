// Per-model metrics of ../shared/docs/METHOD.md section 3 (V3, V2, charts, seam lengths, texture
// size, packing efficiency), the definitions of Maggiordomo et al. 2021 ("Texture Defragmentation
// for Photo-Reconstructed 3D Models", Eurographics 2021) as their program prints them.
#include "texdefrag/core/charts.h"
#include "texdefrag/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace fs = std::filesystem;

namespace texdefrag::eval {
namespace {

uint64_t bits(double d) {
  if (d == 0.0) d = 0.0;  // note: +0 and -0 are the same coordinate
  uint64_t u;
  std::memcpy(&u, &d, sizeof u);
  return u;
}

std::string page_key(const Page& p) {
  if (p.image_path.empty()) return std::string();
  std::error_code ec;
  fs::path abs = fs::absolute(fs::path(p.image_path), ec);
  if (ec) abs = fs::path(p.image_path);
  return abs.lexically_normal().string();
}

void require_page_sizes(const TexturedMesh& mesh) {
  std::vector<uint8_t> used(mesh.pages.size(), 0);
  for (const Face& f : mesh.faces) {
    if (f.page == kNoPage) continue;
    if (f.page < 0 || static_cast<size_t>(f.page) >= mesh.pages.size())
      throw std::invalid_argument("eval: face (OBJ line " + std::to_string(f.source_line) + ") names page " +
                                  std::to_string(f.page) + " of " + std::to_string(mesh.pages.size()));
    for (int k = 0; k < 3; ++k)
      if (f.vt[static_cast<size_t>(k)] < 0 || static_cast<size_t>(f.vt[static_cast<size_t>(k)]) >= mesh.texcoords.size())
        throw std::invalid_argument("eval: textured face (OBJ line " + std::to_string(f.source_line) +
                                    ") has no valid texture coordinate at corner " + std::to_string(k));
    used[static_cast<size_t>(f.page)] = 1;
  }
  for (size_t p = 0; p < mesh.pages.size(); ++p)
    if (used[p] && (mesh.pages[p].width <= 0 || mesh.pages[p].height <= 0))
      throw std::invalid_argument("eval: page " + std::to_string(p) + " ('" + mesh.pages[p].image_path +
                                  "') has unknown size");
}

}  // namespace

TexturedMesh canonical_pages(const TexturedMesh& mesh) {
  TexturedMesh out = mesh;
  out.pages.clear();
  std::vector<int> remap(mesh.pages.size(), kNoPage);
  std::unordered_map<std::string, int> by_key;
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    const std::string key = page_key(mesh.pages[p]);
    if (!key.empty()) {
      auto it = by_key.find(key);
      if (it != by_key.end()) {
        remap[p] = it->second;
        continue;
      }
      by_key.emplace(key, static_cast<int>(out.pages.size()));
    }
    remap[p] = static_cast<int>(out.pages.size());
    out.pages.push_back(mesh.pages[p]);
  }
  for (Face& f : out.faces)
    if (f.page != kNoPage && f.page >= 0 && static_cast<size_t>(f.page) < remap.size())
      f.page = remap[static_cast<size_t>(f.page)];
  return out;
}

ModelMetrics model_metrics(const TexturedMesh& original) {
  const TexturedMesh mesh = canonical_pages(original);
  require_page_sizes(mesh);
  ModelMetrics m;
  m.faces = mesh.faces.size();
  const Topology topo = build_topology(mesh);
  m.topology = topo.report;
  m.v3 = topo.num_vertices();

  // V2: distinct (welded vertex, u, v, page) over the corners of textured faces.
  std::vector<std::tuple<int, uint64_t, uint64_t, int>> corners;
  corners.reserve(mesh.faces.size() * 3);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& fc = mesh.faces[f];
    if (fc.page == kNoPage) continue;
    ++m.textured_faces;
    for (int k = 0; k < 3; ++k) {
      const Vec2& t = mesh.texcoords[static_cast<size_t>(fc.vt[static_cast<size_t>(k)])];
      corners.emplace_back(topo.face_vertex[f][static_cast<size_t>(k)], bits(t.x()), bits(t.y()), fc.page);
    }
  }
  std::sort(corners.begin(), corners.end());
  m.v2 = static_cast<size_t>(std::unique(corners.begin(), corners.end()) - corners.begin());
  m.vertex_replication = m.v3 ? static_cast<double>(m.v2) / static_cast<double>(m.v3) : 0.0;

  const ChartSet cs = build_charts(mesh, topo);
  m.charts = static_cast<size_t>(cs.atlas.num_charts);
  m.zero_area_charts = cs.zero_area_charts;
  m.charts_nonzero = m.charts - m.zero_area_charts;
  m.uv_border_length = cs.uv_border_length;
  m.seam_edges = cs.seam_edges;
  m.seam_length_3d = cs.seam_length_3d;
  for (const ChartStats& s : cs.stats) m.uv_area += s.uv_area;

  m.pages = mesh.pages.size();
  for (const Page& p : mesh.pages) {
    const double area = static_cast<double>(p.width) * static_cast<double>(p.height);
    m.page_area += area;
    std::error_code ec;
    const uintmax_t size = p.image_path.empty() ? static_cast<uintmax_t>(-1) : fs::file_size(p.image_path, ec);
    if (p.image_path.empty() || ec)
      ++m.missing_page_files;
    else
      m.page_bytes += static_cast<uint64_t>(size);
  }
  m.megapixels = m.page_area / 1e6;
  m.packing_efficiency = m.page_area > 0 ? m.uv_area / m.page_area : 0.0;
  m.uv_overlaps = count_uv_overlaps(mesh);
  return m;
}

}  // namespace texdefrag::eval
