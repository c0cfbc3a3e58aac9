// pack_lab: development tool for the packers. Runs a configuration's detector and merger on a
// model once, caches the merged atlas, and packs it with any packers and options, printing the
// packing efficiency, output megapixels and packing time. Used to measure the tables in
// docs/packers.md without re-running the merger for every packer variant.
//
//   pack_lab CONFIG.json MODEL.obj CACHE.atlas [PACKER[:KEY=VALUE,...]]...
//
// CACHE.atlas is written when missing (detector + merger of CONFIG) and read otherwise. Each
// PACKER (e.g. packers.square_tetris:gutter=4,width_trials=8) is run on the cached atlas; one line
// per packer: model, packer, charts, efficiency, output MP, input MP, wall ms, CPU ms (square_tetris
// with an outline tail adds: UV area / outline texels, outline / dilated outline, dilated / page).
#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"

#include <chrono>
#include <ctime>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

using namespace texdefrag;

namespace {

template <class T>
void put(std::ofstream& f, const std::vector<T>& v) {
  const uint64_t n = v.size();
  f.write(reinterpret_cast<const char*>(&n), sizeof n);
  f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}
template <class T>
void get(std::ifstream& f, std::vector<T>& v) {
  uint64_t n = 0;
  f.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!f || n > (1ull << 32)) throw std::runtime_error("pack_lab: corrupt atlas cache");
  v.resize(n);
  f.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
  if (!f) throw std::runtime_error("pack_lab: corrupt atlas cache");
}

void save_atlas(const std::string& path, const Atlas& a) {
  std::ofstream f(path, std::ios::binary);
  std::vector<double> uv;
  for (const Vec2& p : a.wedge_uv) { uv.push_back(p.x()); uv.push_back(p.y()); }
  put(f, uv);
  put(f, a.wedge_vertex);
  put(f, a.face_wedge);
  put(f, a.face_chart);
  put(f, a.chart_page);
  const int32_t n = a.num_charts;
  f.write(reinterpret_cast<const char*>(&n), sizeof n);
  if (!f) throw std::runtime_error("pack_lab: cannot write " + path);
}

Atlas load_atlas(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  Atlas a;
  std::vector<double> uv;
  get(f, uv);
  for (size_t i = 0; i + 1 < uv.size(); i += 2) a.wedge_uv.emplace_back(uv[i], uv[i + 1]);
  get(f, a.wedge_vertex);
  get(f, a.face_wedge);
  get(f, a.face_chart);
  get(f, a.chart_page);
  int32_t n = 0;
  f.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!f) throw std::runtime_error("pack_lab: corrupt atlas cache " + path);
  a.num_charts = n;
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: pack_lab CONFIG.json MODEL.obj CACHE.atlas [PACKER[:KEY=VALUE,...]]...\n";
    return 2;
  }
  try {
    const PipelineConfig cfg = load_config(argv[1]);
    const TexturedMesh mesh = read_obj(argv[2]);
    const Topology topo = build_topology(mesh);
    const ChartSet charts = build_charts(mesh, topo);
    Registry& reg = Registry::instance();
    reg.load_plugins();
    StageContext ctx;
    ctx.mesh = &mesh;
    ctx.topology = &topo;
    ctx.input_charts = &charts;
    ctx.atlas = charts.atlas;
    ctx.progress = [](const std::string&, double) { return true; };
    const std::string cache = argv[3];
    if (std::filesystem::exists(cache)) {
      ctx.atlas = load_atlas(cache);
    } else {
      json node = json::object();
      ctx.report = &node;
      for (const StageConfig* sc : {&cfg.detector, &cfg.merger}) {
        auto st = reg.create(sc->type);
        st->set_options(sc->options);
        if (auto* d = dynamic_cast<Detector*>(st.get())) d->detect(ctx);
        if (auto* m = dynamic_cast<Merger*>(st.get())) m->merge(ctx);
      }
      save_atlas(cache, ctx.atlas);
    }
    double in_mp = 0;
    for (const Page& p : mesh.pages) in_mp += static_cast<double>(p.width) * p.height / 1e6;
    const std::string model = std::filesystem::path(argv[2]).stem().string();
    for (int i = 4; i < argc; ++i) {
      std::string spec = argv[i], name = spec, opts;
      const auto colon = spec.find(':');
      if (colon != std::string::npos) { name = spec.substr(0, colon); opts = spec.substr(colon + 1); }
      json o = json::object();
      std::stringstream ss(opts);
      std::string kv;
      while (std::getline(ss, kv, ',')) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos) throw std::runtime_error("pack_lab: bad option " + kv);
        o[kv.substr(0, eq)] = json::parse(kv.substr(eq + 1));
      }
      const StageInfo* info = reg.find(name);
      if (!info) throw std::runtime_error("pack_lab: no stage " + name);
      auto st = reg.create(name);
      st->set_options(default_options(*info, o));
      StageContext pc;
      pc.mesh = &mesh;
      pc.topology = &topo;
      pc.input_charts = &charts;
      pc.atlas = ctx.atlas;
      pc.progress = ctx.progress;
      json rep = json::object();
      pc.report = &rep;
      const auto t0 = std::chrono::steady_clock::now();
      const std::clock_t c0 = std::clock();
      dynamic_cast<Packer&>(*st).pack(pc);
      const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      double mp = 0;
      for (const auto& ps : pc.layout.pages) mp += static_cast<double>(ps.width) * ps.height / 1e6;
      std::printf("%s\t%s\t%d\t%.3f\t%.3f\t%.2f\t%.0f\t%.0f", model.c_str(), spec.c_str(), ctx.atlas.num_charts,
                  rep.value("packing_efficiency", 0.0), mp, in_mp, ms, cpu_ms);
      // square_tetris: UV area / outline texels / dilated outline texels (where the page goes)
      if (rep.contains("outline_texels"))
        std::printf("\tuv/outline %.3f\toutline/padded %.3f\tpadded/page %.3f",
                    rep.value("chart_uv_area", 0.0) / rep["outline_texels"].get<double>(),
                    rep["outline_texels"].get<double>() / rep["padded_outline_texels"].get<double>(),
                    rep["padded_outline_texels"].get<double>() / (mp * 1e6));
      std::printf("\n");
    }
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
