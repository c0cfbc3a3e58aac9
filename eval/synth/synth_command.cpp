// `texdefrag synth`: synthetic oblique-photogrammetry buildings with ground truth (docs/synth.md).
//   texdefrag synth --archetype hotel --faces 50000 --seed 7 --noise-cm 2 -o OUT
//   texdefrag synth --count 187 --seed 1 -o OUT          (data set + manifest.json)
#include "texdefrag/synth/synth.h"

#include "commands.h"  // cli/commands.h

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

namespace texdefrag::cli {

CLI::App* add_synth_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string archetype = "mixed";
    size_t faces = synth::SynthOptions{}.target_faces;
    uint64_t seed = 1;
    double noise_cm = synth::SynthOptions{}.noise_cm;
    int holes = synth::SynthOptions{}.holes;
    double view_noise = synth::SynthOptions{}.view_noise;
    double view_noise_iid = synth::SynthOptions{}.view_noise_iid;
    int smoothing = synth::SynthOptions{}.smoothing_passes;
    double texels_per_edge = synth::SynthOptions{}.texels_per_edge;
    int page_size = synth::SynthOptions{}.page_size;
    std::string name;
    std::string out;
    size_t count = 0;
    size_t min_faces = synth::DatasetOptions{}.min_faces, max_faces = synth::DatasetOptions{}.max_faces;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("synth", "Generate synthetic photogrammetric building models with ground truth "
                                              "(planes, classes, views, cameras) for benchmarking (docs/synth.md)");
  sub->add_option("--archetype", a->archetype, "building type")
      ->check(CLI::IsMember({"residential", "factory", "hotel", "lshape", "courtyard", "mixed"}));
  sub->add_option("--faces", a->faces, "requested number of triangles (single model)")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->add_option("--seed", a->seed, "random seed; the same seed and options give identical files");
  sub->add_option("--noise-cm", a->noise_cm, "standard deviation of vertex noise, centimetres")->check(CLI::Range(0.0, 100.0));
  sub->add_option("--holes", a->holes, "number of small holes cut into the surface")->check(CLI::Range(0, 1000));
  sub->add_option("--view-noise", a->view_noise, "spatially smooth noise on log view scores (irregular patches)")
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--view-noise-iid", a->view_noise_iid,
                  "per-face noise on log view scores (more = more single-triangle charts)")
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--smoothing", a->smoothing, "majority-vote passes over view labels")->check(CLI::Range(0, 100));
  sub->add_option("--texels-per-edge", a->texels_per_edge, "atlas resolution: texels per mean triangle edge")
      ->check(CLI::Range(0.5, 1000.0));
  sub->add_option("--page-size", a->page_size, "atlas page side, texels (power of two)")
      ->check(CLI::IsMember({256, 512, 1024, 2048, 4096, 8192}));
  sub->add_option("--name", a->name, "file stem of a single model (default: <archetype>_<seed>)");
  sub->add_option("-o,--out", a->out, "output folder (created)")->required();
  sub->add_option("--count", a->count, "data set mode: number of buildings of mixed archetypes and sizes")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(100000)));
  sub->add_option("--min-faces", a->min_faces, "data set mode: smallest face count")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->add_option("--max-faces", a->max_faces, "data set mode: largest face count")
      ->check(CLI::Range(static_cast<size_t>(1000), static_cast<size_t>(5000000)));
  sub->callback([a, &exit_code]() {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      if (a->count > 0) {
        synth::DatasetOptions d;
        d.count = a->count;
        d.seed = a->seed;
        d.min_faces = a->min_faces;
        d.max_faces = a->max_faces;
        d.noise_cm = a->noise_cm;
        if (d.min_faces > d.max_faces) {
          std::cerr << "texdefrag synth: --min-faces " << d.min_faces << " > --max-faces " << d.max_faces << "\n";
          exit_code = 2;
          return;
        }
        const auto manifest = synth::write_dataset(d, a->out, [](size_t done, size_t total) {
          std::fprintf(stderr, "\rsynth: %zu/%zu buildings", done, total);
          if (done == total) std::fprintf(stderr, "\n");
        });
        std::printf("synth: %zu buildings => %s/manifest.json\n", manifest["models"].size(), a->out.c_str());
      } else {
        synth::SynthOptions o;
        o.archetype = *synth::parse_archetype(a->archetype);
        o.target_faces = a->faces;
        o.seed = a->seed;
        o.noise_cm = a->noise_cm;
        o.holes = a->holes;
        o.view_noise = a->view_noise;
        o.view_noise_iid = a->view_noise_iid;
        o.smoothing_passes = a->smoothing;
        o.texels_per_edge = a->texels_per_edge;
        o.page_size = a->page_size;
        synth::SynthModel m = synth::generate(o);
        if (!a->name.empty()) m.name = a->name;
        synth::write_model(m, o, a->out);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("synth: %s (%s) %zu faces, %d planes, %d charts, %zu pages => %s/%s.obj in %.2f s\n",
                    m.name.c_str(), m.truth.archetype.c_str(), m.mesh.faces.size(),
                    static_cast<int>(m.truth.planes.size()), m.truth.num_charts, m.mesh.pages.size(), a->out.c_str(),
                    m.name.c_str(), s);
      }
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
