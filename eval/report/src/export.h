// Internal to eval/report: writing a model view's data files and atlas images.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/eval/report.h"
#include "texdefrag/io/image.h"

#include <string>
#include <vector>

namespace texdefrag::report {

/// One model view to export (the input, or one output).
struct ViewData {
  std::string key;                  ///< file key, e.g. "m0v1" (data/<key>_g<k>.js, data/<key>_t<p>.js)
  const TexturedMesh* mesh = nullptr;  ///< pages canonicalised, sizes known, images readable
  std::vector<int> face_chart;      ///< chart per face (-1 untextured)
  std::vector<int> face_region;     ///< region per face, or empty (no detector)
};

struct ExportOptions {
  std::string data_dir;             ///< the report's data/ folder
  Vec3 centre = Vec3::Zero();       ///< subtracted from positions (the input's bounding-box centre)
  size_t max_faces = 3000000;
  size_t chunk_faces = 60000;
  int texture_max = 2048;
};

struct ViewStats {
  size_t faces = 0, pages = 0, chunks = 0, bytes = 0;
  bool too_large = false;           ///< faces > max_faces: nothing written
};

/// Writes data/<key>_t<p>.js (TD.texture(key, p, jpeg data URL)) per page and
/// data/<key>_g<k>.js (TD.chunk(key, k, {faces, groups: [[page, first, count]...], p, u, c, r}))
/// per chunk of faces sorted by page: p positions (float32 x 9 per face, minus centre), u UVs
/// (float32 x 6), c charts and r regions (int32 per face), all base64 little-endian.
ViewStats export_view(const ViewData& view, const ExportOptions& options);

/// Writes <prefix>_page<p>.png for every page used by a face: the page image scaled so its longer
/// side is at most max_side, chart borders (edges without a UV-continuous face of the same chart
/// across) drawn in yellow. Returns the written paths.
std::vector<std::string> write_atlas_pages(const TexturedMesh& mesh, const std::vector<int>& face_chart,
                                           const std::string& prefix, int max_side);

std::string base64(const void* data, size_t n);
void write_text(const std::string& path, const std::string& text);
/// Area-averaged RGB copy of `im` whose longer side is at most max_side (a copy when smaller).
Image downscale(const Image& im, int max_side);

}  // namespace texdefrag::report
