// Synthetic benchmark generator (issue 3): one building from options, its truth sidecar, files,
// and data sets. The steps (shape, mesh, noise, cameras, views, atlas) each draw from their own
// random stream derived from the seed, so changing one step does not reshuffle the others.
#include "internal.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace texdefrag::synth {

using detail::Rng;

namespace {
constexpr Archetype kConcrete[] = {Archetype::Residential, Archetype::Factory, Archetype::Hotel, Archetype::LShape,
                                   Archetype::Courtyard};

// Random stream ids of the generation steps.
enum Stream : uint64_t { kArchetype = 1, kShape, kMesh, kNoise, kCameras, kTexelScale, kViews, kAtlas, kClutter, kCrossPlane };

double polygon_area(const detail::Polygon& p) {
  auto ring_area = [&](const std::vector<Vec3>& r) {
    Vec3 s = Vec3::Zero();
    for (size_t i = 0; i < r.size(); ++i) s += r[i].cross(r[(i + 1) % r.size()]);
    return 0.5 * std::abs(s.dot(p.normal));
  };
  double a = ring_area(p.outer);
  for (const auto& h : p.holes) a -= ring_area(h);
  return std::max(0.0, a);
}

void check(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("synth: " + what);
}

json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }
}  // namespace

const char* to_string(Archetype a) {
  switch (a) {
    case Archetype::Residential: return "residential";
    case Archetype::Factory: return "factory";
    case Archetype::Hotel: return "hotel";
    case Archetype::LShape: return "lshape";
    case Archetype::Courtyard: return "courtyard";
    case Archetype::Mixed: return "mixed";
  }
  return "?";
}

const char* to_string(SemanticClass c) {
  switch (c) {
    case SemanticClass::Wall: return "wall";
    case SemanticClass::Roof: return "roof";
    case SemanticClass::Ground: return "ground";
    case SemanticClass::Detail: return "detail";
    case SemanticClass::Vegetation: return "vegetation";
  }
  return "?";
}

std::optional<Archetype> parse_archetype(const std::string& name) {
  for (Archetype a : {Archetype::Residential, Archetype::Factory, Archetype::Hotel, Archetype::LShape,
                      Archetype::Courtyard, Archetype::Mixed})
    if (name == to_string(a)) return a;
  return std::nullopt;
}

std::vector<std::string> preset_names() { return {"default", "hard"}; }

bool apply_preset(const std::string& name, SynthOptions& o) {
  if (name == "default") {
    o = SynthOptions{};
    return true;
  }
  if (name != "hard") return false;
  o = SynthOptions{};
  // note: values from the realism table of docs/synth.md (measured on the six real ContextCapture
  // tiles and, for the mirrored share, the held-back L19 tile of issue 18: 46% of its faces).
  o.mirror_fraction = 0.4;
  o.zero_uv_fraction = 0.01;
  o.overlap_fraction = 0.005;
  o.perspective = 0.25;
  o.density_jitter = 0.1;
  o.exposure_sd = 0.06;
  o.clutter_fraction = 0.15;
  o.cross_plane = 0.3;
  o.view_noise = 0.6;
  o.view_noise_iid = 0.15;
  o.smoothing_passes = 1;
  return true;
}

SynthModel generate(const SynthOptions& o) {
  check(o.target_faces >= 1000 && o.target_faces <= 5000000, "target_faces " + std::to_string(o.target_faces) + " outside [1000, 5000000]");
  check(std::isfinite(o.noise_cm) && o.noise_cm >= 0, "noise_cm must be >= 0");
  check(o.holes >= 0, "holes must be >= 0");
  check(std::isfinite(o.view_noise) && o.view_noise >= 0, "view_noise must be >= 0");
  check(std::isfinite(o.view_noise_iid) && o.view_noise_iid >= 0, "view_noise_iid must be >= 0");
  check(o.smoothing_passes >= 0, "smoothing_passes must be >= 0");
  check(std::isfinite(o.texels_per_edge) && o.texels_per_edge > 0, "texels_per_edge must be > 0");
  check(o.padding >= 1 && o.padding <= 8, "padding " + std::to_string(o.padding) + " outside [1, 8]");
  check(o.page_size >= 256 && o.page_size <= 8192 && (o.page_size & (o.page_size - 1)) == 0,
        "page_size must be a power of two in [256, 8192]");
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  check(in(o.mirror_fraction, 0, 1), "mirror_fraction outside [0, 1]");
  check(in(o.zero_uv_fraction, 0, 0.5), "zero_uv_fraction outside [0, 0.5]");
  check(in(o.overlap_fraction, 0, 0.5), "overlap_fraction outside [0, 0.5]");
  check(in(o.perspective, 0, 1.5), "perspective outside [0, 1.5]");
  check(in(o.density_jitter, 0, 1), "density_jitter outside [0, 1]");
  check(in(o.exposure_sd, 0, 0.5), "exposure_sd outside [0, 0.5]");
  check(in(o.clutter_fraction, 0, 0.8), "clutter_fraction outside [0, 0.8]");
  check(in(o.cross_plane, 0, 1), "cross_plane outside [0, 1]");

  Archetype arch = o.archetype;
  if (arch == Archetype::Mixed) arch = kConcrete[Rng(o.seed, kArchetype).uniform_int(0, 4)];
  const double F = static_cast<double>(o.target_faces);
  const double scale = std::clamp(std::pow(F / 20000.0, 0.25), 0.8, 2.0);
  Rng shape_rng(o.seed, kShape);
  detail::Shape shape = detail::build_shape(arch, shape_rng, scale);
  Rng clutter_rng(o.seed, kClutter);
  detail::add_clutter(shape, o.clutter_fraction, clutter_rng);

  // edge length: a jittered hexagonal grid of spacing s gives 2 / (s^2 sin 60deg) faces per m^2;
  // then correct by the predicted face count (cheap: no triangulation) twice.
  double area = 0;
  for (const auto& p : shape.polygons) area += polygon_area(p);
  double edge = std::sqrt(2 * area / (0.8660254037844386 * F));
  for (int it = 0; it < 3; ++it) {
    Rng r(o.seed, kMesh);
    const double pred = static_cast<double>(detail::remesh(shape, edge, r, nullptr));
    edge *= std::sqrt(pred / F);
  }
  detail::RawMesh raw;
  Rng mesh_rng(o.seed, kMesh);
  detail::remesh(shape, edge, mesh_rng, &raw);
  Rng noise_rng(o.seed, kNoise);
  detail::perturb(raw, shape, o.noise_cm / 100.0, o.holes, noise_rng);
  if (raw.tris.empty()) throw std::runtime_error("synth: meshing produced no faces");

  SynthModel model;
  model.name = std::string(to_string(arch)) + "_" + std::to_string(o.seed);
  Rng cam_rng(o.seed, kCameras);
  model.truth.cameras = detail::make_cameras(shape, cam_rng);
  const double tpm = o.texels_per_edge / edge;
  const Vec3 centre = 0.5 * (shape.bbox_min + shape.bbox_max);
  Rng scale_rng(o.seed, kTexelScale);
  for (Camera& c : model.truth.cameras)
    c.texel_scale = tpm * (c.position - centre).norm() / c.focal_px * scale_rng.uniform(0.8, 1.25);
  Rng view_rng(o.seed, kViews), cross_rng(o.seed, kCrossPlane);
  const std::vector<int> views = detail::select_views(raw, shape, model.truth.cameras, o.view_noise, o.view_noise_iid,
                                                        o.smoothing_passes, view_rng, o.cross_plane, cross_rng);
  Rng atlas_rng(o.seed, kAtlas);
  detail::build_atlas(raw, shape, views, o, atlas_rng, model);

  SynthTruth& t = model.truth;
  t.archetype = shape.archetype;
  t.planes = shape.planes;
  std::vector<uint8_t> used(raw.positions.size(), 0);
  for (const auto& f : raw.tris)
    for (int v : f) used[static_cast<size_t>(v)] = 1;
  t.welded_vertices = static_cast<size_t>(std::count(used.begin(), used.end(), 1));
  t.mean_edge_m = edge;
  t.texels_per_metre = tpm;
  return model;
}

json truth_json(const SynthModel& m, const SynthOptions& o) {
  const SynthTruth& t = m.truth;
  json j;
  j["generator"] = "texdefrag synth";
  j["format_version"] = 1;
  j["name"] = m.name;
  j["archetype"] = t.archetype;
  j["options"] = {{"archetype", to_string(o.archetype)}, {"target_faces", o.target_faces}, {"seed", o.seed},
                  {"noise_cm", o.noise_cm}, {"holes", o.holes}, {"view_noise", o.view_noise}, {"view_noise_iid", o.view_noise_iid},
                  {"smoothing_passes", o.smoothing_passes}, {"texels_per_edge", o.texels_per_edge},
                  {"padding", o.padding}, {"page_size", o.page_size}, {"mirror_fraction", o.mirror_fraction},
                  {"zero_uv_fraction", o.zero_uv_fraction}, {"overlap_fraction", o.overlap_fraction},
                  {"perspective", o.perspective}, {"density_jitter", o.density_jitter}, {"exposure_sd", o.exposure_sd},
                  {"clutter_fraction", o.clutter_fraction}, {"cross_plane", o.cross_plane}};
  j["classes"] = {"wall", "roof", "ground", "detail", "vegetation"};
  j["faces"] = m.mesh.faces.size();
  j["pages"] = m.mesh.pages.size();
  j["num_charts"] = t.num_charts;
  j["welded_vertices"] = t.welded_vertices;
  j["mean_edge_m"] = t.mean_edge_m;
  j["texels_per_metre"] = t.texels_per_metre;
  j["face_plane"] = t.face_plane;
  std::vector<int> cls(t.face_class.size());
  for (size_t i = 0; i < cls.size(); ++i) cls[i] = static_cast<int>(t.face_class[i]);
  j["face_class"] = cls;
  j["face_view"] = t.face_view;
  j["face_chart"] = t.face_chart;
  const auto count = [](const std::vector<uint8_t>& v) { return static_cast<size_t>(std::count(v.begin(), v.end(), 1)); };
  json hard = {{"mirrored_faces", count(t.face_mirrored)}, {"zero_uv_faces", count(t.face_zero_uv)},
               {"clutter_faces", t.clutter_faces}, {"plane_edges", t.plane_edges},
               {"plane_edges_in_chart", t.plane_edges_in_chart}, {"overlapping_charts", t.overlapping_charts}};
  if (!t.face_mirrored.empty()) j["face_mirrored"] = t.face_mirrored;
  if (!t.face_zero_uv.empty()) j["face_zero_uv"] = t.face_zero_uv;
  j["features"] = hard;
  json planes = json::array();
  for (const PlaneInfo& p : t.planes)
    planes.push_back({{"class", to_string(p.semantic)}, {"normal", vec_json(p.normal)}, {"offset", p.offset}, {"curved", p.curved}});
  j["planes"] = planes;
  json cams = json::array();
  for (const Camera& c : t.cameras)
    cams.push_back({{"kind", c.kind}, {"position", vec_json(c.position)},
                    {"rotation", {vec_json(c.rotation[0]), vec_json(c.rotation[1]), vec_json(c.rotation[2])}},
                    {"focal_px", c.focal_px}, {"width", c.width}, {"height", c.height},
                    {"texel_scale", c.texel_scale}, {"exposure", c.exposure}, {"colour_gain", vec_json(c.colour_gain)}});
  j["cameras"] = cams;
  return j;
}

void write_model(SynthModel& m, const SynthOptions& o, const std::string& out_dir, int jpeg_quality) {
  check(jpeg_quality >= 1 && jpeg_quality <= 100, "jpeg_quality outside [1, 100]");
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw std::runtime_error("synth: cannot create " + out_dir + ": " + ec.message());
  for (size_t k = 0; k < m.mesh.pages.size(); ++k) {
    const std::string file = m.name + "_" + std::to_string(k) + ".jpg";
    m.mesh.materials[k].map_kd = file;
    m.mesh.pages[k].image_path = (fs::path(out_dir) / file).string();
    write_image(m.mesh.pages[k].image_path, m.pages[k], ImageFormat::Jpeg, jpeg_quality);
  }
  write_obj(m.mesh, (fs::path(out_dir) / (m.name + ".obj")).string());
  write_file_atomic((fs::path(out_dir) / (m.name + ".truth.json")).string(), truth_json(m, o).dump() + "\n");
}

std::vector<SynthOptions> dataset_plan(const DatasetOptions& d) {
  check(d.count >= 1, "count must be >= 1");
  check(d.min_faces >= 1000 && d.min_faces <= d.max_faces && d.max_faces <= 5000000,
        "face range must satisfy 1000 <= min_faces <= max_faces <= 5000000");
  check(std::isfinite(d.noise_cm) && d.noise_cm >= 0, "noise_cm must be >= 0");
  Rng rng(d.seed, 100);
  std::vector<SynthOptions> plan;
  const double l0 = std::log(static_cast<double>(d.min_faces)), l1 = std::log(static_cast<double>(d.max_faces));
  for (size_t i = 0; i < d.count; ++i) {
    SynthOptions o = d.base;
    o.archetype = kConcrete[rng.uniform_int(0, 4)];
    o.target_faces = static_cast<size_t>(std::llround(std::exp(rng.uniform(l0, l1))));
    o.target_faces = std::clamp(o.target_faces, d.min_faces, d.max_faces);
    o.seed = Rng::mix(d.seed ^ Rng::mix(i + 1));
    o.noise_cm = d.noise_cm;
    o.holes = rng.uniform_int(0, 3);
    o.render_pages = d.render_pages;
    plan.push_back(o);
  }
  return plan;
}

json write_dataset(const DatasetOptions& d, const std::string& out_dir, const std::function<void(size_t, size_t)>& progress) {
  const std::vector<SynthOptions> plan = dataset_plan(d);
  json models = json::array();
  for (size_t i = 0; i < plan.size(); ++i) {
    SynthModel m = generate(plan[i]);
    char name[32];
    std::snprintf(name, sizeof name, "b%04zu", i);
    m.name = name;
    write_model(m, plan[i], (fs::path(out_dir) / m.name).string());
    models.push_back({{"name", m.name}, {"obj", m.name + "/" + m.name + ".obj"},
                      {"truth", m.name + "/" + m.name + ".truth.json"}, {"archetype", m.truth.archetype},
                      {"faces", m.mesh.faces.size()}, {"target_faces", plan[i].target_faces},
                      {"seed", plan[i].seed}, {"noise_cm", plan[i].noise_cm}, {"holes", plan[i].holes},
                      {"charts", m.truth.num_charts}, {"pages", m.mesh.pages.size()},
                      {"mirrored_faces", std::count(m.truth.face_mirrored.begin(), m.truth.face_mirrored.end(), 1)},
                      {"clutter_faces", m.truth.clutter_faces}});
    if (progress) progress(i + 1, plan.size());
  }
  json manifest = {{"generator", "texdefrag synth"}, {"format_version", 1}, {"seed", d.seed}, {"count", d.count},
                   {"min_faces", d.min_faces}, {"max_faces", d.max_faces}, {"noise_cm", d.noise_cm},
                   {"preset", d.preset}, {"models", models}};
  write_file_atomic((fs::path(out_dir) / "manifest.json").string(), manifest.dump(2) + "\n");
  return manifest;
}

}  // namespace texdefrag::synth
