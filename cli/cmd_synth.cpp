// `texdefrag synth`: synthetic oblique-photogrammetry buildings with ground truth (docs/synth.md).
//   texdefrag synth --archetype hotel --faces 50000 --seed 7 --noise-cm 2 -o OUT
//   texdefrag synth --count 187 --seed 1 -o OUT          (data set + manifest.json)
//   texdefrag synth --preset hard --count 8 -o OUT       (hard data set)
#include "texdefrag/synth/synth.h"

#include "commands.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

namespace {

/// The arguments of `texdefrag synth`.
struct SynthArgs {
  std::string preset = "default";
  std::string archetype = "mixed";
  size_t faces = synth::SynthOptions{}.target_faces;
  uint64_t seed = 1;
  synth::SynthOptions o;  ///< values of the per-model options given on the command line
  std::string name;
  std::string out;
  size_t count = 0;
  size_t min_faces = synth::DatasetOptions{}.min_faces, max_faces = synth::DatasetOptions{}.max_faces;
};

/// A numeric per-model option: flag, field of SynthOptions, help, range [lo, hi].
struct Num {
  const char* flag;
  double synth::SynthOptions::*field;
  const char* help;
  double lo, hi;
};

const Num kNums[] = {
    {"--noise-cm", &synth::SynthOptions::noise_cm, "standard deviation of vertex noise, centimetres", 0, 100},
    {"--view-noise", &synth::SynthOptions::view_noise, "spatially smooth noise on log view scores (irregular patches)", 0, 10},
    {"--view-noise-iid", &synth::SynthOptions::view_noise_iid,
     "per-face noise on log view scores (more = more single-triangle charts)", 0, 10},
    {"--texels-per-edge", &synth::SynthOptions::texels_per_edge, "atlas resolution: texels per mean triangle edge", 0.5, 1000},
    {"--mirror-fraction", &synth::SynthOptions::mirror_fraction, "share of faces in mirrored charts (u -> -u)", 0, 1},
    {"--zero-uv-fraction", &synth::SynthOptions::zero_uv_fraction, "share of faces with zero UV area", 0, 0.5},
    {"--overlap-fraction", &synth::SynthOptions::overlap_fraction, "share of charts laid over a larger chart", 0, 0.5},
    {"--perspective", &synth::SynthOptions::perspective, "texel-density gradient g inside charts (ratio (1+g/2)/(1-g/2))", 0, 1.5},
    {"--density-jitter", &synth::SynthOptions::density_jitter, "sd of the log of a per-chart texel-density factor", 0, 1},
    {"--exposure-sd", &synth::SynthOptions::exposure_sd, "sd of a per-chart exposure factor", 0, 0.5},
    {"--clutter-fraction", &synth::SynthOptions::clutter_fraction, "share of the surface on trees and ground clutter", 0, 0.8},
    {"--cross-plane", &synth::SynthOptions::cross_plane, "probability that a face next to another plane takes its view", 0, 1},
};

/// Data set mode (--count): writes a.count models with `o` as base and their manifest.json into
/// a.out, with progress on stderr. Returns the exit code (2 for --min-faces > --max-faces).
int synth_dataset(const SynthArgs& a, const synth::SynthOptions& o) {
  synth::DatasetOptions d;
  d.count = a.count;
  d.seed = a.seed;
  d.min_faces = a.min_faces;
  d.max_faces = a.max_faces;
  d.noise_cm = o.noise_cm;
  d.base = o;
  d.preset = a.preset;
  if (d.min_faces > d.max_faces) {
    std::cerr << "texdefrag synth: --min-faces " << d.min_faces << " > --max-faces " << d.max_faces << "\n";
    return 2;
  }
  const auto manifest = synth::write_dataset(d, a.out, [](size_t done, size_t total) {
    std::fprintf(stderr, "\rsynth: %zu/%zu buildings", done, total);
    if (done == total) std::fprintf(stderr, "\n");
  });
  std::printf("synth: %zu buildings => %s/manifest.json\n", manifest["models"].size(), a.out.c_str());
  return 0;
}

/// Single model mode: generates one model of a.archetype from `o` and writes it into a.out; prints
/// one summary line with the time since `t0`.
void synth_model(const SynthArgs& a, synth::SynthOptions o, std::chrono::steady_clock::time_point t0) {
  o.archetype = *synth::parse_archetype(a.archetype);
  o.target_faces = a.faces;
  o.seed = a.seed;
  synth::SynthModel m = synth::generate(o);
  if (!a.name.empty()) m.name = a.name;
  synth::write_model(m, o, a.out);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("synth: %s (%s) %zu faces, %d planes, %d charts, %zu pages => %s/%s.obj in %.2f s\n",
              m.name.c_str(), m.truth.archetype.c_str(), m.mesh.faces.size(),
              static_cast<int>(m.truth.planes.size()), m.truth.num_charts, m.mesh.pages.size(), a.out.c_str(),
              m.name.c_str(), s);
}

}  // namespace

CLI::App* add_synth_command(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<SynthArgs>();
  CLI::App* sub = app.add_subcommand("synth", "Generate synthetic photogrammetric building models with ground truth "
                                              "(planes, classes, views, cameras) for benchmarking (docs/synth.md)");
  sub->add_option("--preset", a->preset, "option set: default, or hard (mirrored charts, zero-UV faces, overlaps, "
                                         "density gradients, exposure steps, trees and clutter; options given "
                                         "explicitly override it)")
      ->check(CLI::IsMember(synth::preset_names()));
  sub->add_option("--archetype", a->archetype, "building type")
      ->check(CLI::IsMember({"residential", "factory", "hotel", "lshape", "courtyard", "mixed"}));
  sub->add_option("--faces", a->faces, "requested number of triangles (single model)")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->add_option("--seed", a->seed, "random seed; the same seed and options give identical files");
  // Per-model options (kNums and three integers); applied over the preset when given.
  std::vector<std::pair<CLI::Option*, const Num*>> given;
  for (const Num& n : kNums)
    given.emplace_back(sub->add_option(n.flag, a->o.*n.field, n.help)->check(CLI::Range(n.lo, n.hi)), &n);
  CLI::Option* holes = sub->add_option("--holes", a->o.holes, "number of small holes cut into the surface")->check(CLI::Range(0, 1000));
  CLI::Option* smoothing = sub->add_option("--smoothing", a->o.smoothing_passes, "majority-vote passes over view labels")->check(CLI::Range(0, 100));
  CLI::Option* page = sub->add_option("--page-size", a->o.page_size, "atlas page side, texels (power of two)")
                          ->check(CLI::IsMember({256, 512, 1024, 2048, 4096, 8192}));
  sub->add_option("--name", a->name, "file stem of a single model (default: <archetype>_<seed>)");
  sub->add_option("-o,--out", a->out, "output folder (created)")->required();
  sub->add_option("--count", a->count, "data set mode: number of buildings of mixed archetypes and sizes")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(100000)));
  sub->add_option("--min-faces", a->min_faces, "data set mode: smallest face count")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->add_option("--max-faces", a->max_faces, "data set mode: largest face count")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->callback([a, given, holes, smoothing, page, &exit_code]() {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      synth::SynthOptions o;
      synth::apply_preset(a->preset, o);
      for (const auto& [opt, n] : given)
        if (opt->count() > 0) o.*(n->field) = a->o.*(n->field);
      if (holes->count() > 0) o.holes = a->o.holes;
      if (smoothing->count() > 0) o.smoothing_passes = a->o.smoothing_passes;
      if (page->count() > 0) o.page_size = a->o.page_size;
      if (a->count > 0) {
        exit_code = synth_dataset(*a, o);
        return;
      }
      synth_model(*a, o, t0);
      exit_code = 0;
    } catch (const std::invalid_argument& e) {
      std::cerr << "texdefrag synth: " << e.what() << "\n";
      exit_code = 2;
    } catch (const std::exception& e) {
      std::cerr << "texdefrag synth: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

}  // namespace texdefrag::cli
