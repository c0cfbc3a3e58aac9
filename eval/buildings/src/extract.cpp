#include "texdefrag/buildings/extract.h"

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>

namespace fs = std::filesystem;

namespace texdefrag::buildings {
namespace {

/// Runs detectors.semantic (regions: components) and returns its regions and report.
std::pair<Regions, json> classify(const TexturedMesh& mesh, const json& detector_options) {
  Registry& reg = Registry::instance();
  reg.load_plugins();
  const StageInfo* info = reg.find("detectors.semantic");
  if (!info) throw StageError("texdefrag buildings: the stage detectors.semantic is not installed");
  json values = detector_options;
  values["regions"] = "components";
  std::vector<std::string> errors;
  const Options opts = make_options(*info, values, "detector", errors);
  if (!errors.empty()) throw ConfigError(errors);
  std::unique_ptr<Stage> stage = reg.create(info->name);
  auto* det = dynamic_cast<Detector*>(stage.get());
  det->set_options(opts);
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  json report = json::object();
  StageContext ctx;
  ctx.mesh = &mesh;
  ctx.topology = &topo;
  ctx.input_charts = &charts;
  ctx.atlas = charts.atlas;
  ctx.report = &report;
  ctx.progress = [](const std::string&, double) { return true; };
  det->detect(ctx);
  return {ctx.regions, report};
}

/// Exact bit pattern of a face's corners (positions, then texture coordinates or a marker).
std::string face_key(const TexturedMesh& m, size_t f) {
  std::string k;
  auto put = [&k](double d) { k.append(reinterpret_cast<const char*>(&d), sizeof d); };
  for (int c = 0; c < 3; ++c) {
    const Vec3& p = m.corner_position(f, c);
    put(p.x()), put(p.y()), put(p.z());
    const int vt = m.faces[f].vt[static_cast<size_t>(c)];
    if (vt < 0) k.push_back('-');
    else put(m.texcoords[static_cast<size_t>(vt)].x()), put(m.texcoords[static_cast<size_t>(vt)].y());
  }
  return k;
}

}  // namespace

Extraction extract_buildings(const TexturedMesh& mesh, const ExtractOptions& options) {
  if (options.min_faces < 1) throw ConfigError({"buildings: 'min_faces' = " + std::to_string(options.min_faces) + " must be >= 1"});
  auto [regions, report] = classify(mesh, options.detector);
  const json& region_class = report.at("region_class");
  std::vector<std::vector<size_t>> members(static_cast<size_t>(regions.num_regions));
  Part rest{"rest", {}};
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const int r = regions.face_region[f];
    if (r >= 0 && region_class.at(static_cast<size_t>(r)) == "building") members[static_cast<size_t>(r)].push_back(f);
    else rest.faces.push_back(f);
  }
  Extraction ex;
  for (auto& m : members) {  // regions are numbered by decreasing size: buildings come largest first
    if (m.empty()) continue;
    if (static_cast<int>(m.size()) < options.min_faces) {
      rest.faces.insert(rest.faces.end(), m.begin(), m.end());
      continue;
    }
    ex.parts.push_back({"building_" + std::to_string(ex.parts.size()), std::move(m)});
  }
  std::sort(rest.faces.begin(), rest.faces.end());
  ex.parts.push_back(std::move(rest));
  ex.detector_report = std::move(report);
  return ex;
}

TexturedMesh sub_mesh(const TexturedMesh& mesh, const std::vector<size_t>& faces) {
  TexturedMesh out;
  out.materials = mesh.materials;
  out.pages = mesh.pages;
  out.groups = mesh.groups;
  std::vector<int> vmap(mesh.positions.size(), -1), tmap(mesh.texcoords.size(), -1), nmap(mesh.normals.size(), -1);
  auto remap = [](int i, std::vector<int>& map, auto& dst, const auto& src) {
    if (i < 0) return i;
    int& m = map[static_cast<size_t>(i)];
    if (m < 0) m = static_cast<int>(dst.size()), dst.push_back(src[static_cast<size_t>(i)]);
    return m;
  };
  for (size_t f : faces) {
    Face F = mesh.faces[f];
    for (size_t k = 0; k < 3; ++k) {
      F.v[k] = remap(F.v[k], vmap, out.positions, mesh.positions);
      F.vt[k] = remap(F.vt[k], tmap, out.texcoords, mesh.texcoords);
      F.vn[k] = remap(F.vn[k], nmap, out.normals, mesh.normals);
    }
    out.faces.push_back(F);
  }
  return out;
}

json write_parts(const TexturedMesh& mesh, const std::string& input_path, const Extraction& ex, const std::string& out_dir) {
  fs::create_directories(out_dir);
  const fs::path in_dir = fs::weakly_canonical(fs::absolute(input_path)).parent_path();
  if (fs::equivalent(in_dir, fs::canonical(out_dir)))
    throw std::runtime_error(out_dir + ": the output folder must not be the input's folder");
  const std::string stem = fs::path(input_path).stem().string();
  std::vector<std::string> protect{input_path};
  // Page images: copied once, under their own names (an index prefix where two names collide).
  std::vector<Page> pages = mesh.pages;
  std::map<std::string, int> used_names;
  for (size_t p = 0; p < pages.size(); ++p) {
    protect.push_back(pages[p].image_path);
    std::string name = fs::path(pages[p].image_path).filename().string();
    if (used_names[name]++) name = std::to_string(p) + "_" + name;
    const fs::path dst = fs::path(out_dir) / name;
    fs::copy_file(pages[p].image_path, dst, fs::copy_options::overwrite_existing);
    pages[p].image_path = dst.string();
  }
  json manifest = {{"input", input_path}, {"detector", ex.detector_report}, {"parts", json::array()}};
  std::map<std::string, long> pending;
  for (size_t f = 0; f < mesh.faces.size(); ++f) ++pending[face_key(mesh, f)];
  for (const Part& part : ex.parts) {
    if (part.faces.empty()) continue;
    TexturedMesh sm = sub_mesh(mesh, part.faces);
    sm.pages = pages;
    const std::string obj = (fs::path(out_dir) / (stem + "_" + part.name + ".obj")).string();
    ObjWriteOptions wo;
    wo.protected_paths = protect;
    write_obj(sm, obj, wo);
    const TexturedMesh back = read_obj(obj);
    for (size_t f = 0; f < back.faces.size(); ++f)
      if (--pending[face_key(back, f)] < 0)
        throw std::runtime_error(obj + ": face " + std::to_string(f) + " (line " + std::to_string(back.faces[f].source_line) +
                                 ") is not an input face, or is written twice");
    manifest["parts"].push_back({{"name", part.name}, {"obj", fs::path(obj).filename().string()}, {"faces", part.faces.size()}});
  }
  for (const auto& [key, n] : pending)
    if (n != 0) throw std::runtime_error(out_dir + ": " + std::to_string(n) + " input face(s) missing from the written parts");
  write_file_atomic((fs::path(out_dir) / (stem + "_buildings.json")).string(), manifest.dump(2) + "\n");
  return manifest;
}

}  // namespace texdefrag::buildings
