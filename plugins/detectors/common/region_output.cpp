#include "common/region_output.h"

#include "common/label_io.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <algorithm>
#include <cmath>
#include <cctype>
#include <filesystem>
#include <map>
#include <numeric>

namespace texdefrag::detectors {

std::vector<OptionSpec> output_options() {
  return {
      opt_output_path("write_labels",
                 "Write the regions as a per-face label file of this name in the output folder (the format "
                 "detectors.labels reads; .json = JSON, else one integer per line); empty = off"),
      opt_output_path("write_colored",
                 "Write a region-coloured model (OBJ + MTL + palette PNG) of this .obj name in the output "
                 "folder; empty = off"),
  };
}

void check_region_output_options(const std::string& who, const Options& options) {
  const std::string colored = options.get_string("write_colored");
  if (colored.empty()) return;
  std::string ext = std::filesystem::path(colored).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".obj")
    throw StageError(who + ": write_colored '" + colored + "' must name an .obj file (its MTL and palette PNG are written " +
                     "beside it as <stem>.mtl and <stem>_palette.png)");
}

Regions regions_from_labels(const std::vector<int>& face_label) {
  std::map<int, std::pair<int, size_t>> count;  // label -> (faces, first face)
  for (size_t f = 0; f < face_label.size(); ++f) {
    if (face_label[f] < 0) continue;
    auto it = count.find(face_label[f]);
    if (it == count.end()) count.emplace(face_label[f], std::make_pair(1, f));
    else ++it->second.first;
  }
  std::vector<std::pair<int, std::pair<int, size_t>>> order(count.begin(), count.end());
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) {
    if (a.second.first != b.second.first) return a.second.first > b.second.first;
    return a.second.second < b.second.second;
  });
  std::map<int, int> id;
  for (size_t i = 0; i < order.size(); ++i) id[order[i].first] = static_cast<int>(i);
  Regions r;
  r.num_regions = static_cast<int>(order.size());
  r.face_region.assign(face_label.size(), -1);
  for (size_t f = 0; f < face_label.size(); ++f)
    if (face_label[f] >= 0) r.face_region[f] = id[face_label[f]];
  return r;
}

void report_region_stats(const Regions& regions, json& report) {
  std::vector<int> faces(static_cast<size_t>(regions.num_regions), 0);
  size_t textured = 0;
  for (int r : regions.face_region)
    if (r >= 0) {
      ++faces[static_cast<size_t>(r)];
      ++textured;
    }
  report["textured_faces"] = textured;
  if (faces.empty()) return;
  std::vector<int> s = faces;
  std::sort(s.begin(), s.end());
  report["faces_per_region"] = {{"min", s.front()},
                                {"median", s[s.size() / 2]},
                                {"mean", static_cast<double>(textured) / static_cast<double>(s.size())},
                                {"max", s.back()}};
  report["largest_region_fraction"] = static_cast<double>(s.back()) / static_cast<double>(textured);
  size_t single = 0;
  for (int n : s) single += n == 1;
  report["single_face_regions"] = single;
}

void write_region_outputs(const std::string& who, const Options& options, const StageContext& ctx) {
  const std::string labels = options.get_string("write_labels");
  const std::string colored = options.get_string("write_colored");
  // note: every file goes through the run's write service (names relative to the output folder,
  // never onto an input file); the stage never chooses a path itself.
  if (!labels.empty()) {
    write_face_labels(who, ctx.output_path(who, labels), ctx.regions);
    if (ctx.report) (*ctx.report)["wrote_labels"] = labels;
  }
  if (!colored.empty()) {
    namespace fs = std::filesystem;
    const fs::path name(colored);
    const std::string obj = ctx.output_path(who, colored);
    ctx.output_path(who, (name.parent_path() / (name.stem().string() + ".mtl")).string());
    ctx.output_path(who, (name.parent_path() / (name.stem().string() + "_palette.png")).string());
    write_colored_model(who, obj, *ctx.mesh, ctx.regions);
    if (ctx.report) (*ctx.report)["wrote_colored"] = colored;
  }
}

std::array<uint8_t, 3> region_colour(int region) {
  if (region < 0) return {128, 128, 128};
  // note: golden-ratio steps in hue give neighbouring ids well separated colours; saturation and
  // value alternate so that ids a full hue turn apart still differ.
  const double h = std::fmod(0.1 + 0.618033988749895 * region, 1.0) * 6.0;
  const double s = (region % 3 == 0) ? 0.85 : (region % 3 == 1 ? 0.6 : 0.75);
  const double v = (region % 2 == 0) ? 0.95 : 0.75;
  const int i = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = 0, g = 0, b = 0;
  switch (i) {
    case 0: r = v; g = t; b = p; break;
    case 1: r = q; g = v; b = p; break;
    case 2: r = p; g = v; b = t; break;
    case 3: r = p; g = q; b = v; break;
    case 4: r = t; g = p; b = v; break;
    default: r = v; g = p; b = q; break;
  }
  return {static_cast<uint8_t>(std::lround(r * 255)), static_cast<uint8_t>(std::lround(g * 255)),
          static_cast<uint8_t>(std::lround(b * 255))};
}

void write_colored_model(const std::string& who, const std::string& obj_path, const TexturedMesh& mesh,
                         const Regions& regions) {
  namespace fs = std::filesystem;
  if (regions.face_region.size() != mesh.faces.size())
    throw StageError(who + ": write_colored: regions cover " + std::to_string(regions.face_region.size()) +
                     " faces, the mesh has " + std::to_string(mesh.faces.size()));
  const fs::path obj(obj_path);
  const std::string png_name = obj.stem().string() + "_palette.png";
  const fs::path png = obj.parent_path() / png_name;
  constexpr int kCell = 4;
  const int cells = regions.num_regions + 1;  // last cell: untextured grey
  const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(cells)))));
  const int rows = (cells + cols - 1) / cols;
  Image img;
  img.width = cols * kCell;
  img.height = rows * kCell;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 0);
  TexturedMesh out;
  out.positions = mesh.positions;
  out.normals = mesh.normals;
  out.groups = mesh.groups;
  Material mat;
  mat.name = "regions";
  mat.extra_lines = {"Ka 1 1 1", "Kd 1 1 1", "Ks 0 0 0"};
  mat.map_kd = png_name;
  out.materials.push_back(mat);
  Page page;
  page.material = "regions";
  page.image_path = png.string();
  page.width = img.width;
  page.height = img.height;
  out.pages.push_back(page);
  for (int c = 0; c < cells; ++c) {
    const int region = c == cells - 1 ? -1 : c;
    const auto col = region_colour(region);
    const int cx = (c % cols) * kCell, cy = (c / cols) * kCell;  // cy: row from the top
    for (int y = cy; y < cy + kCell; ++y)
      for (int x = cx; x < cx + kCell; ++x) std::copy(col.begin(), col.end(), img.at(x, y));
    // Texel centre of the cell in normalised (u, v), v up.
    out.texcoords.emplace_back((cx + 0.5 * kCell) / img.width, 1.0 - (cy + 0.5 * kCell) / img.height);
  }
  out.faces = mesh.faces;
  for (size_t f = 0; f < out.faces.size(); ++f) {
    Face& fc = out.faces[f];
    const int r = regions.face_region[f];
    const int cell = r >= 0 ? r : cells - 1;
    fc.vt = {cell, cell, cell};
    fc.material = 0;
    fc.page = 0;
  }
  try {
    if (!obj.parent_path().empty()) fs::create_directories(obj.parent_path());
    write_image(png.string(), img, ImageFormat::Png);
    write_obj(out, obj_path);
  } catch (const std::exception& e) {
    throw StageError(who + ": write_colored '" + obj_path + "': " + e.what());
  }
}

}  // namespace texdefrag::detectors
