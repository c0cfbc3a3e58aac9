// detectors_eval: measures the detectors against ground truth and renders their regions.
//
//   detectors_eval synth [--archetypes a,b,..] [--seeds 1,2,..] [--faces N] [--noise-cm X]
//                        [--config NAME[=JSON]]...
//     Generates synthetic buildings in memory (eval/synth, no page images), runs every configuration
//     (a detector name, optionally with option overrides as a JSON object) and prints per-model and
//     per-archetype plane-labelling accuracy (common/accuracy.h), region counts, over-/under-
//     segmentation and the number of regions mixing walls and roofs.
//   detectors_eval stats OBJ...
//     Prints the median and 90th percentile angle between the normals of faces sharing a manifold
//     edge (how noisy a mesh is; compare real tiles with synthetic ones).
//   detectors_eval render OBJ PNG [--config NAME[=JSON]] [--size N] [--crop x0,y0,x1,y1]
//     Runs the detector on a model and writes an oblique region-coloured render (texdefrag::bench
//     render_3d, the paper's Figure 11c style), and prints the detector's report. The configuration
//     --crop keeps the faces whose centroid lies in that fraction of the x/y bounding box. The
//     configuration "components" colours the edge-connected components of the welded mesh instead.
// A development tool for docs/detectors.md; the tests assert what matters.
#include "common/accuracy.h"
#include "common/test_meshes.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/bench.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/synth/synth.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace texdefrag;
namespace tmesh = texdefrag::detectors::testmesh;

namespace {

struct Config {
  std::string label, name;
  json options = json::object();
};

Config parse_config(const std::string& s) {
  Config c;
  const size_t eq = s.find('=');
  c.name = s.substr(0, eq);
  if (eq != std::string::npos) c.options = json::parse(s.substr(eq + 1));
  c.label = s;
  return c;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

/// Median and 90th percentile of the angle (degrees) between faces sharing a manifold edge.
std::pair<double, double> dihedral_noise(const TexturedMesh& mesh) {
  const Topology topo = build_topology(mesh);
  std::vector<double> a;
  for (const Edge& e : topo.edges) {
    if (e.num_faces != 2) continue;
    const size_t f = static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence)].face);
    const size_t g = static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence) + 1].face);
    const Vec3 nf = face_normal(mesh, f), ng = face_normal(mesh, g);
    if (nf.norm() > 0 && ng.norm() > 0) a.push_back(std::acos(std::clamp(nf.normalized().dot(ng.normalized()), -1.0, 1.0)) * 180 / M_PI);
  }
  if (a.empty()) return {0, 0};
  std::sort(a.begin(), a.end());
  return {a[a.size() / 2], a[a.size() * 9 / 10]};
}

struct Row {
  double main_accuracy = 0;
  double accuracy = 0, regions = 0, truth = 0, over = 0, under = 0, mixed = 0, seconds = 0;
  int n = 0;
  void add(const Row& r) {
    main_accuracy += r.main_accuracy;
    accuracy += r.accuracy, regions += r.regions, truth += r.truth, over += r.over, under += r.under;
    mixed += r.mixed, seconds += r.seconds, ++n;
  }
  void print(const std::string& what, const std::string& cfg) const {
    const double k = n > 0 ? 1.0 / n : 1.0;
    std::printf("%-22s %-60s acc %.3f main %.3f regions %7.1f truth %5.1f over %5.1f under %5.1f wall+roof %4.1f  %.3f s\n",
                what.c_str(), cfg.c_str(), accuracy * k, main_accuracy * k, regions * k, truth * k, over * k, under * k, mixed * k,
                seconds * k);
  }
};

/// Regions holding at least 10% wall faces and 10% roof faces (and >= 10 faces).
int wall_roof_regions(const std::vector<int>& region, const std::vector<synth::SemanticClass>& cls, bool verbose) {
  std::map<int, std::array<int, 3>> count;  // wall, roof, all
  for (size_t f = 0; f < region.size(); ++f) {
    if (region[f] < 0) continue;
    auto& c = count[region[f]];
    c[0] += cls[f] == synth::SemanticClass::Wall;
    c[1] += cls[f] == synth::SemanticClass::Roof;
    ++c[2];
  }
  int mixed = 0;
  for (const auto& [r, c] : count) {
    const bool m = c[2] >= 10 && c[0] >= 0.1 * c[2] && c[1] >= 0.1 * c[2];
    mixed += m;
    if (m && verbose) std::printf("  region %d: %d faces, %d wall, %d roof\n", r, c[2], c[0], c[1]);
  }
  return mixed;
}

/// With --stats: prints the regions holding >= 20 faces of each of two or more main planes, and
/// the main planes (>= 50 faces) split with no part of 90% of their faces. main_truth: per face its
/// main plane or -1; face_region: the detector's regions.
void print_plane_mixing(const std::vector<int>& face_region, const std::vector<int>& main_truth,
                        const synth::SynthTruth& truth) {
  std::map<int, std::map<int, int>> parts;
  for (size_t f = 0; f < main_truth.size(); ++f)
    if (main_truth[f] >= 0) ++parts[face_region[f]][main_truth[f]];
  for (const auto& [reg, planes] : parts) {
    std::string line;
    int big = 0;
    for (const auto& [pl, cnt] : planes) {
      if (cnt < 20) continue;
      ++big;
      const auto& P = truth.planes[static_cast<size_t>(pl)];
      char buf[160];
      std::snprintf(buf, sizeof buf, " plane %d (%s, n %.2f %.2f %.2f, off %.2f): %d", pl, synth::to_string(P.semantic),
                    P.normal.x(), P.normal.y(), P.normal.z(), P.offset, cnt);
      line += buf;
    }
    if (big >= 2) std::printf("  region %d holds%s\n", reg, line.c_str());
  }
  std::map<int, std::map<int, int>> split_of;  // main plane -> region -> faces
  for (size_t f = 0; f < main_truth.size(); ++f)
    if (main_truth[f] >= 0) ++split_of[main_truth[f]][face_region[f]];
  for (const auto& [pl, regs] : split_of) {
    int all = 0, top = 0;
    for (const auto& [rg, cnt] : regs) all += cnt, top = std::max(top, cnt);
    if (all < 50 || top >= 0.9 * all) continue;
    const auto& P = truth.planes[static_cast<size_t>(pl)];
    std::printf("  plane %d (%s%s, n %.2f %.2f %.2f) of %d faces split, largest part %d, %zu regions\n", pl,
                synth::to_string(P.semantic), P.curved ? " curved" : "", P.normal.x(), P.normal.y(), P.normal.z(), all,
                top, regs.size());
  }
}

/// A synthetic model of archetype `arch` (std::invalid_argument when unknown), seed `seed`, about
/// `faces` faces and `noise` cm of vertex noise, without page images.
synth::SynthModel synth_model(const std::string& arch, const std::string& seed, size_t faces, double noise) {
  synth::SynthOptions o;
  const auto at = synth::parse_archetype(arch);
  if (!at) throw std::invalid_argument("unknown archetype " + arch);
  o.archetype = *at;
  o.seed = std::stoull(seed);
  o.target_faces = faces;
  o.noise_cm = noise;
  o.render_pages = false;
  return synth::generate(o);
}

int run_synth(int argc, char** argv) {
  std::vector<std::string> archetypes = {"residential", "factory", "hotel", "lshape", "courtyard"};
  std::vector<std::string> seeds = {"1"};
  size_t faces = 10000;
  double noise = 2.0;
  bool stats = false;
  std::vector<Config> configs;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--stats") {
      stats = true;
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--archetypes") archetypes = split(v);
    else if (a == "--seeds") seeds = split(v);
    else if (a == "--faces") faces = std::stoul(v);
    else if (a == "--noise-cm") noise = std::stod(v);
    else if (a == "--config") configs.push_back(parse_config(v));
    else throw std::invalid_argument("unknown argument " + a);
  }
  if (configs.empty()) configs = {parse_config("detectors.region_growing"), parse_config("detectors.angle_growing")};
  std::vector<Row> total(configs.size());
  for (const std::string& arch : archetypes) {
    std::vector<Row> per(configs.size());
    for (const std::string& seed : seeds) {
      const synth::SynthModel m = synth_model(arch, seed, faces, noise);
      // "main": faces of detail planes (window reveals, chimneys, slabs) are not counted.
      std::vector<int> main_truth = m.truth.face_plane;
      for (size_t f = 0; f < main_truth.size(); ++f)
        if (m.truth.face_class[f] == synth::SemanticClass::Detail) main_truth[f] = -1;
      if (stats) {
        const auto [med, p90] = dihedral_noise(m.mesh);
        std::printf("%s_%s: %zu faces, face-normal angle across edges median %.1f p90 %.1f deg\n", arch.c_str(),
                    seed.c_str(), m.mesh.faces.size(), med, p90);
      }
      for (size_t k = 0; k < configs.size(); ++k) {
        const auto t0 = std::chrono::steady_clock::now();
        const tmesh::Detection d = tmesh::run_detector(configs[k].name, m.mesh, configs[k].options);
        Row r;
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const auto s = detectors::score_segmentation(d.regions.face_region, m.truth.face_plane);
        r.accuracy = s.accuracy, r.regions = s.regions, r.truth = s.truth_planes, r.over = s.over_segmented;
        if (stats) print_plane_mixing(d.regions.face_region, main_truth, m.truth);
        r.main_accuracy = detectors::score_segmentation(d.regions.face_region, main_truth).accuracy;
        r.under = s.under_segmented, r.mixed = wall_roof_regions(d.regions.face_region, m.truth.face_class, stats);
        r.print(arch + "_" + seed + " " + std::to_string(m.mesh.faces.size()), configs[k].label);
        per[k].add(r);
        total[k].add(r);
      }
    }
    for (size_t k = 0; k < configs.size(); ++k) per[k].print("MEAN " + arch, configs[k].label);
  }
  for (size_t k = 0; k < configs.size(); ++k) total[k].print("MEAN all", configs[k].label);
  return 0;
}

int run_render(int argc, char** argv) {
  if (argc < 4) throw std::invalid_argument("render OBJ PNG [--config NAME[=JSON]] [--size N]");
  const std::string obj = argv[2], png = argv[3];
  Config cfg = parse_config("detectors.region_growing");
  int size = 1024;
  std::array<double, 4> crop = {0, 0, 1, 1};
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--config") cfg = parse_config(v);
    else if (a == "--size") size = std::stoi(v);
    else if (a == "--crop") {
      const auto c = split(v);
      if (c.size() != 4) throw std::invalid_argument("--crop expects x0,y0,x1,y1 (fractions of the bounding box)");
      for (size_t k = 0; k < 4; ++k) crop[k] = std::stod(c[k]);
    } else throw std::invalid_argument("unknown argument " + a);
  }
  const TexturedMesh mesh = read_obj(obj);
  if (cfg.name == "components") {  // connected components over welded edges (are there cracks?)
    const Topology topo = build_topology(mesh);
    std::vector<int> comp(mesh.faces.size(), -1);
    int nc = 0;
    for (size_t s0 = 0; s0 < mesh.faces.size(); ++s0) {
      if (comp[s0] >= 0) continue;
      std::vector<size_t> stack{s0};
      comp[s0] = nc;
      while (!stack.empty()) {
        const size_t f = stack.back();
        stack.pop_back();
        for (int k = 0; k < 3; ++k) {
          const Edge& e = topo.edges[static_cast<size_t>(topo.face_edge[f][static_cast<size_t>(k)])];
          for (int i = 0; i < e.num_faces; ++i) {
            const size_t g = static_cast<size_t>(topo.edge_faces[static_cast<size_t>(e.first_incidence + i)].face);
            if (comp[g] < 0) comp[g] = nc, stack.push_back(g);
          }
        }
      }
      ++nc;
    }
    write_image(png, bench::render_3d(mesh, comp, size), ImageFormat::Png);
    std::printf("%s: %zu faces, %d edge-connected components\n", obj.c_str(), mesh.faces.size(), nc);
    return 0;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const tmesh::Detection d = tmesh::run_detector(cfg.name, mesh, cfg.options);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Crop: faces whose centroid lies in the given fraction of the x/y bounding box (a closer look).
  TexturedMesh shown = mesh;
  std::vector<int> colour;
  Vec3 lo = Vec3::Constant(1e300), hi = -lo;
  for (const Face& f : mesh.faces)
    for (int v : f.v) lo = lo.cwiseMin(mesh.positions[static_cast<size_t>(v)]), hi = hi.cwiseMax(mesh.positions[static_cast<size_t>(v)]);
  shown.faces.clear();
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Vec3 c = Vec3::Zero();
    for (int v : mesh.faces[f].v) c += mesh.positions[static_cast<size_t>(v)] / 3;
    const double fx = (c.x() - lo.x()) / std::max(hi.x() - lo.x(), 1e-12), fy = (c.y() - lo.y()) / std::max(hi.y() - lo.y(), 1e-12);
    if (fx < crop[0] || fx > crop[2] || fy < crop[1] || fy > crop[3]) continue;
    shown.faces.push_back(mesh.faces[f]);
    colour.push_back(d.regions.face_region[f]);
  }
  write_image(png, bench::render_3d(shown, colour, size), ImageFormat::Png);
  std::printf("%s: %zu faces, %.3f s incl. topology+charts\n%s\n", obj.c_str(), mesh.faces.size(), s,
              d.report.dump().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "synth") return run_synth(argc, argv);
    if (mode == "render") return run_render(argc, argv);
    if (mode == "stats") {
      for (int i = 2; i < argc; ++i) {
        const auto [med, p90] = dihedral_noise(read_obj(argv[i]));
        std::printf("%s: face-normal angle across edges median %.1f p90 %.1f deg\n", argv[i], med, p90);
      }
      return 0;
    }
    std::fprintf(stderr, "usage: detectors_eval synth [...] | render OBJ PNG [...] (see the source's header)\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "detectors_eval: %s\n", e.what());
    return 1;
  }
}
