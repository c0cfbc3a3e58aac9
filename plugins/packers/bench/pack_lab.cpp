// pack_lab: development tool for the packers. Runs a configuration's detector and merger on a
// model once, caches the merged atlas, and packs it with any packers and options, printing the
// packing efficiency, output megapixels and packing time. Used to measure the tables in
// docs/packers.md without re-running the merger for every packer variant.
//
//   pack_lab CONFIG.json MODEL CACHE.atlas [PACKER[:KEY=VALUE,...]]...
//
// MODEL: any model file texdefrag reads, or glTF files sharing an atlas joined by '+' (read as one
// model). With the environment variable PACK_LAB_OVERLAPS set, also prints overlapping UV triangle
// pairs of the input, the merged atlas and every packing, split into pairs inside one chart and
// across charts, by intersection area, and the pairs each step added. PACK_LAB_HASH prints a hash of
// each layout (page sizes, chart pages, wedge UVs, bit for bit), to check a change keeps layouts.
// PACK_LAB_THREADS=N sets the thread count (default: every core; 1 for repeatable callgrind counts).
// CACHE.atlas is written when missing (detector + merger of CONFIG) and read otherwise. Each
// PACKER (e.g. packers.square_tetris:gutter=4,width_trials=8) is run on the cached atlas; one line
// per packer: model, packer, charts, efficiency, output MP, input MP, wall ms, CPU ms (square_tetris
// with an outline tail adds: UV area / outline texels, outline / dilated outline, dilated / page, and
// the pages trimmed to their charts before rounding / page).
// square_tetris adds its angle search's report (packings, charts turned, MP before, free trial kept).
// PACK_LAB_PAGES=PREFIX writes each packing's pages as PREFIX_<packer>_<page>.ppm, every chart's
// faces in a colour of its own (texel centres inside a face), to look at a layout.
#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/core/uv_overlap.h"
#include "texdefrag/io/gltf_format.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
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

/// Overlapping pairs of UV triangles of one UV state, split by whether both faces are in the same
/// chart (per page; page = chart's input page, or its output page with a layout), and the number of
/// faces with zero UV area. Sweep over x with the exact test of core/uv_overlap.h.
struct OverlapSplit {
  size_t same_chart = 0, cross_chart = 0, zero_area = 0;
  size_t above[3] = {0, 0, 0};  ///< pairs whose intersection area exceeds 1e-8, 1e-6, 1e-4 texels^2
  std::vector<std::pair<int, int>> pairs;  ///< face pairs, smaller face first
};

/// Area of the intersection of two triangles (convex clipping, double precision).
double intersection_area(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b) {
  std::vector<Vec2> poly(a.begin(), a.end());
  const double sb = (b[1] - b[0]).x() * (b[2] - b[0]).y() - (b[1] - b[0]).y() * (b[2] - b[0]).x();
  for (int k = 0; k < 3 && !poly.empty(); ++k) {
    const Vec2 p = b[static_cast<size_t>(k)], q = b[static_cast<size_t>((k + 1) % 3)];
    auto side = [&](const Vec2& v) { return ((q - p).x() * (v - p).y() - (q - p).y() * (v - p).x()) * (sb > 0 ? 1 : -1); };
    std::vector<Vec2> out;
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec2 u = poly[i], v = poly[(i + 1) % poly.size()];
      const double su = side(u), sv = side(v);
      if (su >= 0) out.push_back(u);
      if ((su >= 0) != (sv >= 0)) out.push_back(u + (v - u) * (su / (su - sv)));
    }
    poly = out;
  }
  double area = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Vec2 u = poly[i], v = poly[(i + 1) % poly.size()];
    area += u.x() * v.y() - u.y() * v.x();
  }
  return std::abs(area) / 2;
}

OverlapSplit overlap_split(const TexturedMesh& mesh, const Atlas& a, const Layout* layout) {
  struct Tri {
    std::array<Vec2, 3> p;
    double x0, x1, y0, y1;
    int chart, page, face;
  };
  std::vector<Tri> tris;
  OverlapSplit r;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (a.face_chart[f] < 0) continue;
    Tri t;
    t.chart = a.face_chart[f];
    t.face = static_cast<int>(f);
    t.page = layout ? layout->chart_page[static_cast<size_t>(t.chart)] : a.chart_page[static_cast<size_t>(t.chart)];
    for (size_t k = 0; k < 3; ++k) {
      const size_t w = static_cast<size_t>(a.face_wedge[f][k]);
      t.p[k] = layout ? layout->wedge_uv[w] : a.wedge_uv[w];
    }
    if (orient2d(t.p[0], t.p[1], t.p[2]) == 0) { ++r.zero_area; continue; }
    t.x0 = std::min({t.p[0].x(), t.p[1].x(), t.p[2].x()});
    t.x1 = std::max({t.p[0].x(), t.p[1].x(), t.p[2].x()});
    t.y0 = std::min({t.p[0].y(), t.p[1].y(), t.p[2].y()});
    t.y1 = std::max({t.p[0].y(), t.p[1].y(), t.p[2].y()});
    tris.push_back(t);
  }
  std::sort(tris.begin(), tris.end(), [](const Tri& u, const Tri& v) { return u.x0 < v.x0; });
  for (size_t i = 0; i < tris.size(); ++i)
    for (size_t j = i + 1; j < tris.size() && tris[j].x0 < tris[i].x1; ++j) {
      const Tri &u = tris[i], &v = tris[j];
      if (u.page != v.page || !(u.y0 < v.y1 && v.y0 < u.y1)) continue;
      if (!triangle_interiors_overlap(u.p, v.p)) continue;
      (u.chart == v.chart ? r.same_chart : r.cross_chart)++;
      if (u.chart == v.chart || layout) {
        const double ar = intersection_area(u.p, v.p);
        r.above[0] += ar > 1e-8;
        r.above[1] += ar > 1e-6;
        r.above[2] += ar > 1e-4;
      }
      // note: unpacked charts overlap each other freely; only pairs inside a chart are compared
      if (u.chart == v.chart || layout) r.pairs.emplace_back(std::min(u.face, v.face), std::max(u.face, v.face));
    }
  std::sort(r.pairs.begin(), r.pairs.end());
  return r;
}

std::array<Vec2, 3> face_uv(const Atlas& a, const Layout* layout, int f) {
  std::array<Vec2, 3> t;
  for (size_t k = 0; k < 3; ++k) {
    const size_t w = static_cast<size_t>(a.face_wedge[static_cast<size_t>(f)][k]);
    t[k] = layout ? layout->wedge_uv[w] : a.wedge_uv[w];
  }
  return t;
}

/// Prints the pairs of `now` that `before` lacks: intersection area, UV areas before of both faces.
void print_new_pairs(const char* what, const OverlapSplit& before, const OverlapSplit& now, const Atlas& ab,
                     const Atlas& an, const Layout* layout, size_t max_lines) {
  std::vector<std::pair<int, int>> added;
  std::set_difference(now.pairs.begin(), now.pairs.end(), before.pairs.begin(), before.pairs.end(),
                      std::back_inserter(added));
  std::vector<std::pair<int, int>> gone;
  std::set_difference(before.pairs.begin(), before.pairs.end(), now.pairs.begin(), now.pairs.end(),
                      std::back_inserter(gone));
  int hist[8] = {0};
  for (const auto& [f, g] : added) {
    const double ar = intersection_area(face_uv(an, layout, f), face_uv(an, layout, g));
    int b = 0;
    for (double t = 1e-12; b < 7 && ar > t; t *= 100) ++b;
    ++hist[b];
  }
  std::printf("%s: %zu pairs added, %zu gone; added by intersection area (texels^2) <=1e-12: %d, <=1e-10: %d, <=1e-8: %d, "
              "<=1e-6: %d, <=1e-4: %d, <=1e-2: %d, <=1: %d, >1: %d\n", what, added.size(), gone.size(), hist[0], hist[1],
              hist[2], hist[3], hist[4], hist[5], hist[6], hist[7]);
  for (size_t i = 0; i < added.size() && i < max_lines; ++i) {
    const auto [f, g] = added[i];
    std::printf("  faces %d %d: area now %.3g, face areas before %.3g %.3g, now %.3g %.3g\n", f, g,
                intersection_area(face_uv(an, layout, f), face_uv(an, layout, g)), atlas_face_area(ab, f),
                atlas_face_area(ab, g), layout ? 0.0 : atlas_face_area(an, f), layout ? 0.0 : atlas_face_area(an, g));
  }
}

/// Reads MODEL: any model file texdefrag reads, or glTF files sharing an atlas joined by '+'.
LoadedModel read_model(const std::string& model_arg) {
  // note: "A.glb+B.glb+..." reads glTF files sharing an atlas as one model, as a tileset run does.
  if (model_arg.find('+') == std::string::npos) return format_for_input(model_arg).read(model_arg);
  std::vector<GltfInput> group;
  std::stringstream ms(model_arg);
  std::string part;
  while (std::getline(ms, part, '+')) group.push_back(GltfInput{part, {}, ""});
  return GltfFormat().read_group(group, std::filesystem::path(group[0].path).parent_path().string());
}

/// The merged atlas: read from `cache` when it exists, else made by cfg's detector and merger on
/// ctx (ctx.atlas = the input charts) and written there.
void merged_atlas(StageContext& ctx, const PipelineConfig& cfg, const std::string& cache) {
  if (std::filesystem::exists(cache)) {
    ctx.atlas = load_atlas(cache);
    return;
  }
  Registry& reg = Registry::instance();
  json node = json::object();
  ctx.report = &node;
  for (const StageConfig* sc : {&cfg.detector, &cfg.merger}) {
    auto st = reg.create(sc->type);
    st->set_options(sc->options);
    if (auto* d = dynamic_cast<Detector*>(st.get())) d->detect(ctx);
    if (auto* m = dynamic_cast<Merger*>(st.get())) m->merge(ctx);
  }
  ctx.report = nullptr;
  save_atlas(cache, ctx.atlas);
}

/// The overlapping pairs of the input and the merged atlas (PACK_LAB_OVERLAPS).
void print_input_overlaps(const TexturedMesh& mesh, const ChartSet& charts, const Atlas& merged) {
  const OverlapSplit in = overlap_split(mesh, charts.atlas, nullptr);
  const OverlapSplit mg = overlap_split(mesh, merged, nullptr);
  std::printf("overlaps input: same-chart %zu cross-chart %zu zero-area %zu; merged: same %zu cross %zu zero %zu\n",
              in.same_chart, in.cross_chart, in.zero_area, mg.same_chart, mg.cross_chart, mg.zero_area);
  std::printf("pairs inside charts with area > 1e-8/1e-6/1e-4: input %zu/%zu/%zu merged %zu/%zu/%zu\n", in.above[0],
              in.above[1], in.above[2], mg.above[0], mg.above[1], mg.above[2]);
  print_new_pairs("merger", in, mg, charts.atlas, merged, nullptr, 12);
}

/// A PACKER argument: stage name and options ("NAME[:KEY=VALUE,...]", values in JSON).
std::pair<std::string, json> parse_packer_spec(const std::string& spec) {
  std::string name = spec, opts;
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
  return {name, o};
}

/// FNV-1a of a layout: page sizes, chart pages, wedge UVs (bit for bit).
uint64_t layout_hash(const Layout& layout) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* p, size_t n) {
    for (size_t k = 0; k < n; ++k) h = (h ^ static_cast<const unsigned char*>(p)[k]) * 1099511628211ull;
  };
  for (const auto& ps : layout.pages) { mix(&ps.width, sizeof ps.width); mix(&ps.height, sizeof ps.height); }
  mix(layout.chart_page.data(), layout.chart_page.size() * sizeof(int));
  for (const Vec2& p : layout.wedge_uv) { const double xy[2] = {p.x(), p.y()}; mix(xy, sizeof xy); }
  return h;
}

/// What every packing of one run shares: the model, its input charts and the merged atlas.
struct Lab {
  const TexturedMesh* mesh = nullptr;
  const Topology* topology = nullptr;
  const ChartSet* charts = nullptr;
  const Atlas* merged = nullptr;
  std::string model;  ///< the model's file stem
  double in_mp = 0;   ///< input pages, megapixels
  bool overlaps = false;
};

/// Writes the pages of `layout` as binary PPM images, PREFIX_<page>.ppm: black where no face lies,
/// each chart's faces (texel centres inside them) in a colour hashed from its id.
void write_pages(const Atlas& a, const Layout& layout, const std::string& prefix) {
  for (size_t p = 0; p < layout.pages.size(); ++p) {
    const int w = layout.pages[p].width, h = layout.pages[p].height;
    std::vector<unsigned char> img(static_cast<size_t>(w) * static_cast<size_t>(h) * 3, 0);
    for (size_t f = 0; f < a.face_wedge.size(); ++f) {
      const int c = a.face_chart[f];
      if (c < 0 || a.face_wedge[f][0] < 0 || layout.chart_page[static_cast<size_t>(c)] != static_cast<int>(p)) continue;
      Vec2 v[3];
      for (int k = 0; k < 3; ++k) v[k] = layout.wedge_uv[static_cast<size_t>(a.face_wedge[f][static_cast<size_t>(k)])];
      const unsigned hc = static_cast<unsigned>(c) * 2654435761u;
      const unsigned char col[3] = {static_cast<unsigned char>(64 + (hc >> 8) % 192),
                                    static_cast<unsigned char>(64 + (hc >> 16) % 192),
                                    static_cast<unsigned char>(64 + (hc >> 24) % 192)};
      const double x0 = std::min({v[0].x(), v[1].x(), v[2].x()}), x1 = std::max({v[0].x(), v[1].x(), v[2].x()});
      const double y0 = std::min({v[0].y(), v[1].y(), v[2].y()}), y1 = std::max({v[0].y(), v[1].y(), v[2].y()});
      auto edge = [](const Vec2& s, const Vec2& e, double x, double y) {
        return (e.x() - s.x()) * (y - s.y()) - (e.y() - s.y()) * (x - s.x());
      };
      for (int y = std::max(0, static_cast<int>(y0)); y <= std::min(h - 1, static_cast<int>(y1)); ++y)
        for (int x = std::max(0, static_cast<int>(x0)); x <= std::min(w - 1, static_cast<int>(x1)); ++x) {
          const double cx = x + 0.5, cy = y + 0.5;
          const double e0 = edge(v[0], v[1], cx, cy), e1 = edge(v[1], v[2], cx, cy), e2 = edge(v[2], v[0], cx, cy);
          if (!((e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0))) continue;
          unsigned char* px = &img[(static_cast<size_t>(h - 1 - y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * 3];
          std::copy(col, col + 3, px);
        }
    }
    for (int c = 0; c < a.num_charts; ++c) {  // each chart's placed box and UV area
      if (layout.chart_page[static_cast<size_t>(c)] != static_cast<int>(p)) continue;
      double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300, area = 0;
      for (size_t f = 0; f < a.face_wedge.size(); ++f) {
        if (a.face_chart[f] != c || a.face_wedge[f][0] < 0) continue;
        Vec2 v[3];
        for (int k = 0; k < 3; ++k) v[k] = layout.wedge_uv[static_cast<size_t>(a.face_wedge[f][static_cast<size_t>(k)])];
        for (const Vec2& q : v) x0 = std::min(x0, q.x()), x1 = std::max(x1, q.x()), y0 = std::min(y0, q.y()), y1 = std::max(y1, q.y());
        area += 0.5 * std::abs((v[1] - v[0]).x() * (v[2] - v[0]).y() - (v[1] - v[0]).y() * (v[2] - v[0]).x());
      }
      if (area > 0)
        std::fprintf(stderr, "page %zu chart %d box [%.0f %.0f]x[%.0f %.0f] %.0fx%.0f uv %.0f fill %.2f\n", p, c, x0, x1, y0,
                     y1, x1 - x0, y1 - y0, area, area / ((x1 - x0) * (y1 - y0)));
    }
    std::ofstream out(prefix + "_" + std::to_string(p) + ".ppm", std::ios::binary);
    out << "P6\n" << w << " " << h << "\n255\n";
    out.write(reinterpret_cast<const char*>(img.data()), static_cast<std::streamsize>(img.size()));
  }
}

/// Texels^2 of pc's pages trimmed to their charts as the packers trim them before rounding (the
/// largest wedge coordinate, rounded up, plus the gutter's upper share; gutter from options o, else 4).
double trimmed_area(const StageContext& pc, const json& o) {
  const int gutter = o.contains("gutter") ? o["gutter"].get<int>() : 4;
  const int hi = gutter - gutter / 2;
  std::vector<double> w(pc.layout.pages.size(), 0), h(pc.layout.pages.size(), 0);
  for (size_t f = 0; f < pc.atlas.face_chart.size(); ++f) {
    const int page = pc.layout.chart_page[static_cast<size_t>(pc.atlas.face_chart[f])];
    if (page < 0) continue;
    for (int wi : pc.atlas.face_wedge[f]) {
      const Vec2& uv = pc.layout.wedge_uv[static_cast<size_t>(wi)];
      w[static_cast<size_t>(page)] = std::max(w[static_cast<size_t>(page)], std::ceil(uv.x() - 1e-6) + hi);
      h[static_cast<size_t>(page)] = std::max(h[static_cast<size_t>(page)], std::ceil(uv.y() - 1e-6) + hi);
    }
  }
  double area = 0;
  for (size_t k = 0; k < w.size(); ++k) area += w[k] * h[k];
  return area;
}

/// Packs the merged atlas with one PACKER argument and prints its line (see the top of the file).
void run_packer(const Lab& lab, const std::string& spec, int index) {
  const auto [name, o] = parse_packer_spec(spec);
  Registry& reg = Registry::instance();
  const StageInfo* info = reg.find(name);
  if (!info) throw std::runtime_error("pack_lab: no stage " + name);
  auto st = reg.create(name);
  st->set_options(default_options(*info, o));
  StageContext pc;
  pc.mesh = lab.mesh;
  pc.topology = lab.topology;
  pc.input_charts = lab.charts;
  pc.atlas = *lab.merged;
  pc.progress = [](const std::string&, double) { return true; };
  json rep = json::object();
  pc.report = &rep;
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  dynamic_cast<Packer&>(*st).pack(pc);
  const double cpu_ms = 1000.0 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  double mp = 0;
  for (const auto& ps : pc.layout.pages) mp += static_cast<double>(ps.width) * ps.height / 1e6;
  std::printf("%s\t%s\t%d\t%.3f\t%.4f\t%.2f\t%.0f\t%.0f", lab.model.c_str(), spec.c_str(), lab.merged->num_charts,
              rep.value("packing_efficiency", 0.0), mp, lab.in_mp, ms, cpu_ms);
  if (std::getenv("PACK_LAB_HASH"))
    std::printf("\tlayout %016llx", static_cast<unsigned long long>(layout_hash(pc.layout)));
  if (const char* prefix = std::getenv("PACK_LAB_PAGES"))
    write_pages(pc.atlas, pc.layout, std::string(prefix) + "_" + std::to_string(index));
  if (std::getenv("PACK_LAB_CHARTS"))
    std::printf("\texact %d free-rotated %d", rep.value("charts_exact", 0), rep.value("charts_rotated_free", 0));
  if (rep.contains("angle_search_packings"))  // square_tetris's angle search
    std::printf("\tangles: packings %d turned %d MP before %.3f free_trial %d", rep.value("angle_search_packings", 0),
                rep.value("angle_search_charts_turned", 0), rep.value("angle_search_megapixels_before", 0.0),
                rep.value("free_trial_kept", false) ? 1 : 0);
  if (rep.contains("angle_search_width_trials"))
    std::printf(" trials %d skipped %d replayed %d", rep.value("angle_search_width_trials", 0),
                rep.value("angle_search_width_trials_skipped", 0), rep.value("angle_search_placements_replayed", 0));
  // square_tetris: UV area / outline texels / dilated outline texels (where the page goes)
  if (rep.contains("outline_texels"))
    std::printf("\tuv/outline %.3f\toutline/padded %.3f\tpadded/page %.3f",
                rep.value("chart_uv_area", 0.0) / rep["outline_texels"].get<double>(),
                rep["outline_texels"].get<double>() / rep["padded_outline_texels"].get<double>(),
                rep["padded_outline_texels"].get<double>() / (mp * 1e6));
  // the pages trimmed to their charts (before rounding to page_multiple): what the rounding costs
  if (rep.contains("outline_texels")) std::printf("\ttrimmed/page %.3f", trimmed_area(pc, o) / (mp * 1e6));
  if (lab.overlaps) {
    const OverlapSplit ov = overlap_split(*lab.mesh, pc.atlas, &pc.layout);
    std::printf("\tpacked overlaps: same %zu cross %zu zero %zu\n", ov.same_chart, ov.cross_chart, ov.zero_area);
    std::printf("packed pairs with area > 1e-8/1e-6/1e-4: %zu/%zu/%zu\n", ov.above[0], ov.above[1], ov.above[2]);
    print_new_pairs("packer", overlap_split(*lab.mesh, *lab.merged, nullptr), ov, *lab.merged, pc.atlas, &pc.layout, 5);
  }
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: pack_lab CONFIG.json MODEL CACHE.atlas [PACKER[:KEY=VALUE,...]]...\n";
    return 2;
  }
  try {
    if (const char* t = std::getenv("PACK_LAB_THREADS")) set_thread_count(std::atoi(t));
    const PipelineConfig cfg = load_config(argv[1]);
    const LoadedModel loaded = read_model(argv[2]);
    const TexturedMesh& mesh = loaded.mesh;
    const Topology topo = build_topology(mesh);
    const ChartSet charts = build_charts(mesh, topo);
    Registry::instance().load_plugins();
    StageContext ctx;
    ctx.mesh = &mesh;
    ctx.topology = &topo;
    ctx.input_charts = &charts;
    ctx.atlas = charts.atlas;
    ctx.progress = [](const std::string&, double) { return true; };
    merged_atlas(ctx, cfg, argv[3]);
    Lab lab{&mesh, &topo, &charts, &ctx.atlas, std::filesystem::path(argv[2]).stem().string(), 0.0,
            std::getenv("PACK_LAB_OVERLAPS") != nullptr};
    for (const Page& p : mesh.pages) lab.in_mp += static_cast<double>(p.width) * p.height / 1e6;
    if (lab.overlaps) print_input_overlaps(mesh, charts, ctx.atlas);
    for (int i = 4; i < argc; ++i) run_packer(lab, argv[i], i - 3);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}
