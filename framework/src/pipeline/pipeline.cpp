#include "texdefrag/pipeline/pipeline.h"

#include "texdefrag/core/distortion.h"
#include "texdefrag/core/uv_overlap.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/io/output_set.h"
#include "texdefrag/texture/resample.h"
#include "texdefrag/util/memory.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <exception>
#include <memory>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Times a step and records its figures under report["stages"][name].
template <class F>
void timed(json& report, const std::string& name, F&& fn) {
  const size_t rss_start = current_rss_bytes();
  reset_peak_rss();
  json& node = report["stages"][name];
  if (node.is_null()) node = json::object();
  const auto t0 = Clock::now();
  const double c0 = process_cpu_seconds();
  fn(node);
  node["time_s"] = seconds_since(t0);
  node["cpu_s"] = process_cpu_seconds() - c0;
  node["peak_rss_bytes"] = peak_rss_bytes();
  node["rss_start_bytes"] = rss_start;
}

json chart_summary(const ChartSet& cs) {
  return {{"charts", cs.atlas.num_charts},
          {"zero_area_charts", cs.zero_area_charts},
          {"seam_edges", cs.seam_edges},
          {"seam_length_3d", cs.seam_length_3d},
          {"uv_border_length_texels", cs.uv_border_length},
          {"wedges", cs.atlas.wedge_uv.size()}};
}

json topology_summary(const TopologyReport& t) {
  return {{"welded_vertices", t.welded_vertices},       {"edges", t.edges},
          {"boundary_edges", t.boundary_edges},         {"non_manifold_edges", t.non_manifold_edges},
          {"non_manifold_vertices", t.non_manifold_vertices}, {"degenerate_faces", t.degenerate_faces},
          {"zero_area_faces", t.zero_area_faces},       {"duplicate_faces", t.duplicate_faces}};
}

/// A progress function that forwards only changes of at least 1% (and every stage start/end).
ProgressFn rate_limited(const ProgressFn& user) {
  if (!user) return [](const std::string&, double) { return true; };
  auto last_stage = std::make_shared<std::string>();
  auto last = std::make_shared<double>(-1.0);
  return [user, last_stage, last](const std::string& stage, double f) {
    if (stage != *last_stage || f >= 1.0 || f <= 0.0 || f - *last >= 0.01) {
      *last_stage = stage;
      *last = f;
      return user(stage, f);
    }
    return true;
  };
}

/// The detector's contract: its regions partition the textured faces (every textured face in one
/// region of [0, num_regions), no empty region) and no untextured face is in a region.
void check_regions(const StageContext& ctx, const std::string& stage) {
  const Regions& r = ctx.regions;
  if (r.face_region.size() != ctx.mesh->faces.size())
    throw StageError(stage + ": produced " + std::to_string(r.face_region.size()) + " face regions for " +
                     std::to_string(ctx.mesh->faces.size()) + " faces");
  if (r.num_regions < 0) throw StageError(stage + ": produced " + std::to_string(r.num_regions) + " regions");
  std::vector<uint8_t> used(static_cast<size_t>(r.num_regions), 0);
  for (size_t f = 0; f < r.face_region.size(); ++f) {
    const bool textured = ctx.mesh->faces[f].page != kNoPage;
    const int g = r.face_region[f];
    if (textured && (g < 0 || g >= r.num_regions))
      throw StageError(stage + ": face " + std::to_string(f) + " has region " + std::to_string(g) +
                       " outside [0, " + std::to_string(r.num_regions) + ")");
    if (!textured && g != -1)
      throw StageError(stage + ": face " + std::to_string(f) + " is untextured but has region " + std::to_string(g) +
                       " (regions partition the textured faces; untextured faces have -1)");
    if (textured) used[static_cast<size_t>(g)] = 1;
  }
  for (size_t g = 0; g < used.size(); ++g)
    if (!used[g]) throw StageError(stage + ": region " + std::to_string(g) + " has no face (regions are numbered 0..n-1, none empty)");
}

/// Pairs of UV triangles whose interiors overlap by more than kCountedOverlapArea, counted per page:
/// the input's (texels of the input pages) or, with a layout, the packed output's (texels of the
/// output pages).
size_t uv_overlap_pairs(const TexturedMesh& mesh, const Atlas& atlas, const Layout* layout) {
  std::vector<std::vector<std::array<Vec2, 3>>> per_page(layout ? layout->pages.size() : mesh.pages.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (mesh.faces[f].page == kNoPage) continue;
    std::array<Vec2, 3> t;
    size_t page = static_cast<size_t>(mesh.faces[f].page);
    if (layout) {
      page = static_cast<size_t>(layout->chart_page[static_cast<size_t>(atlas.face_chart[f])]);
      for (size_t k = 0; k < 3; ++k) t[k] = layout->wedge_uv[static_cast<size_t>(atlas.face_wedge[f][k])];
    } else {
      for (int k = 0; k < 3; ++k) t[static_cast<size_t>(k)] = mesh.corner_texel(f, k);
    }
    per_page[page].push_back(t);
  }
  size_t n = 0;
  for (const auto& tris : per_page) n += count_overlapping_pairs(tris, kCountedOverlapArea);
  return n;
}

/// Pairs of UV triangles of one chart overlapping by more than kCountedOverlapArea, summed over the
/// charts of a working atlas (texels of the input pages; charts are not placed yet, so pairs of
/// different charts are not counted).
size_t chart_overlap_pairs(const TexturedMesh& mesh, const Atlas& atlas) {
  std::vector<std::vector<std::array<Vec2, 3>>> per_chart(static_cast<size_t>(atlas.num_charts));
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (mesh.faces[f].page == kNoPage) continue;
    std::array<Vec2, 3> t;
    for (size_t k = 0; k < 3; ++k) t[k] = atlas.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][k])];
    per_chart[static_cast<size_t>(atlas.face_chart[f])].push_back(t);
  }
  size_t n = 0;
  for (const auto& tris : per_chart) n += count_overlapping_pairs(tris, kCountedOverlapArea);
  return n;
}

/// Report keys the framework writes into every stage's node; a stage that writes one is an error
/// (one name per figure, and the framework's figures cannot be forged).
const char* const kReservedKeys[] = {"section", "time_s", "cpu_s", "peak_rss_bytes", "rss_start_bytes", "regions", "charts_in",
                                     "charts_out", "distortion_arap", "flipped_faces", "pages_out",
                                     "uv_overlap_pairs"};

void check_reserved_keys(const json& node, const std::string& stage) {
  for (const char* k : kReservedKeys)
    if (node.contains(k))
      throw StageError(stage + ": wrote report key '" + k + "', which the framework reserves for its own figure");
}

void check_atlas(const StageContext& ctx, const std::string& stage) {
  const Atlas& a = ctx.atlas;
  const size_t nf = ctx.mesh->faces.size();
  if (a.face_chart.size() != nf || a.face_wedge.size() != nf)
    throw StageError(stage + ": the atlas no longer has one entry per face");
  for (size_t f = 0; f < nf; ++f) {
    const bool textured = ctx.mesh->faces[f].page != kNoPage;
    if (!textured) continue;
    if (a.face_chart[f] < 0 || a.face_chart[f] >= a.num_charts)
      throw StageError(stage + ": face " + std::to_string(f) + " lost its chart");
    for (int w : a.face_wedge[f])
      if (w < 0 || static_cast<size_t>(w) >= a.wedge_uv.size() || !std::isfinite(a.wedge_uv[static_cast<size_t>(w)].x()) ||
          !std::isfinite(a.wedge_uv[static_cast<size_t>(w)].y()))
        throw StageError(stage + ": face " + std::to_string(f) + " has an invalid or non-finite UV");
  }
}

void check_layout(const StageContext& ctx, const std::string& stage) {
  const Layout& l = ctx.layout;
  const Atlas& a = ctx.atlas;
  if (l.chart_page.size() != static_cast<size_t>(a.num_charts) || l.wedge_uv.size() != a.wedge_uv.size())
    throw StageError(stage + ": layout does not place every chart and wedge");
  for (const auto& p : l.pages)
    if (p.width <= 0 || p.height <= 0) throw StageError(stage + ": produced an empty page");
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    const int c = a.face_chart[f];
    if (c < 0) continue;
    const int page = l.chart_page[static_cast<size_t>(c)];
    if (page < 0 || static_cast<size_t>(page) >= l.pages.size())
      throw StageError(stage + ": chart " + std::to_string(c) + " placed on page " + std::to_string(page) + " of " +
                       std::to_string(l.pages.size()));
    for (int w : a.face_wedge[f]) {
      const Vec2& p = l.wedge_uv[static_cast<size_t>(w)];
      const auto& ps = l.pages[static_cast<size_t>(page)];
      if (!(p.x() >= 0 && p.y() >= 0 && p.x() <= ps.width && p.y() <= ps.height))
        throw StageError(stage + ": chart " + std::to_string(c) + " placed outside its page");
    }
  }
}

/// Every file the run reads: the reader's files (model, MTLs, pages, ...) and every input-path option.
std::vector<std::string> protected_inputs(const PipelineConfig& config, const LoadedModel& model) {
  std::vector<std::string> p = model.input_files;
  p.insert(p.end(), model.mesh.source_files.begin(), model.mesh.source_files.end());
  for (const std::string& f : config.input_files) p.push_back(f);
  return p;
}

std::string canonical_or_absolute(const std::string& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  return ec ? fs::absolute(p).string() : c.string();
}

}  // namespace

DistortionSummary report_merger_figures(const TexturedMesh& mesh, int charts_in, const Atlas& atlas, json& node) {
  node["charts_in"] = charts_in;
  node["charts_out"] = atlas.num_charts;
  const DistortionSummary d = atlas_distortion(mesh, atlas);
  node["distortion_arap"] = d.arap;
  node["flipped_faces"] = d.flipped;
  return d;
}

void check_merger_distortion(const std::string& stage, const DistortionSummary& d, std::optional<double> budget) {
  const bool over = budget && d.arap > *budget * (1 + 1e-9);
  if (d.flipped == 0 && !over) return;
  std::ostringstream os;
  os << stage << ": after merging, flipped faces " << d.flipped << " (the input: 0), ARAP distortion " << d.arap;
  if (budget) os << " (the merger's budget: " << *budget << ")";
  os << ", measured by core/distortion.h";
  throw StageError(os.str());
}

namespace {

// make_output_mesh's steps, in the order it runs them.

/// Appends one material and one Page per layout page to `out` (material "page_<p>", image
/// `<stem>_page<p>.<image_ext>` in output_dir, the layout page's size); the materials take the
/// extra MTL lines of the first textured input face's material.
void add_page_materials(const TexturedMesh& input, const Layout& layout, const std::string& stem,
                        const std::string& image_ext, const std::string& output_dir, TexturedMesh& out) {
  Material base;
  for (const Face& f : input.faces)
    if (f.page != kNoPage && f.material >= 0) {
      base = input.materials[static_cast<size_t>(f.material)];
      break;
    }
  for (size_t p = 0; p < layout.pages.size(); ++p) {
    Material m;
    m.name = "page_" + std::to_string(p);
    m.extra_lines = base.extra_lines;
    const std::string file = stem + "_page" + std::to_string(p) + "." + image_ext;
    m.map_kd = file;
    out.materials.push_back(m);
    Page pg;
    pg.material = m.name;
    pg.image_path = (fs::path(output_dir) / file).string();
    pg.width = layout.pages[p].width;
    pg.height = layout.pages[p].height;
    out.pages.push_back(pg);
  }
}

/// Drops from out.materials the input materials no face uses any more (those of textured faces);
/// the page materials (from first_page_material on) stay. Returns old index -> new index (-1: dropped).
std::vector<int> drop_unused_materials(const TexturedMesh& input, int first_page_material, TexturedMesh& out) {
  std::vector<int> used(out.materials.size(), 0);
  for (size_t f = 0; f < out.faces.size(); ++f)
    if (input.faces[f].page == kNoPage && input.faces[f].material >= 0) used[static_cast<size_t>(input.faces[f].material)] = 1;
  for (size_t m = static_cast<size_t>(first_page_material); m < used.size(); ++m) used[m] = 1;
  std::vector<int> remap(out.materials.size(), -1);
  std::vector<Material> kept;
  for (size_t m = 0; m < out.materials.size(); ++m)
    if (used[m]) {
      remap[m] = static_cast<int>(kept.size());
      kept.push_back(out.materials[m]);
    }
  out.materials.swap(kept);
  return remap;
}

/// Sets every face's page, material (through `remap`) and texture coordinates: textured faces take
/// their wedges' layout UVs normalised by their page's size (texcoord index = wedge index);
/// faces without a page keep their input texture coordinates, appended after the wedges.
void assign_texcoords(const TexturedMesh& input, const Atlas& atlas, const Layout& layout, const std::vector<int>& remap,
                      int first_page_material, TexturedMesh& out) {
  out.texcoords.resize(atlas.wedge_uv.size());
  std::vector<uint8_t> set(atlas.wedge_uv.size(), 0);
  for (size_t f = 0; f < out.faces.size(); ++f) {
    Face& F = out.faces[f];
    if (input.faces[f].page == kNoPage) {
      if (F.material >= 0) F.material = remap[static_cast<size_t>(F.material)];
      // Texture coordinates of faces without a page (no usemtl, or a material without image) are
      // carried over as they are.
      for (int k = 0; k < 3; ++k) {
        int& vt = F.vt[static_cast<size_t>(k)];
        if (vt < 0) continue;
        out.texcoords.push_back(input.texcoords[static_cast<size_t>(vt)]);
        vt = static_cast<int>(out.texcoords.size()) - 1;
      }
      continue;
    }
    const int c = atlas.face_chart[f];
    const int page = layout.chart_page[static_cast<size_t>(c)];
    F.page = page;
    F.material = remap[static_cast<size_t>(first_page_material + page)];
    const auto& ps = layout.pages[static_cast<size_t>(page)];
    for (int k = 0; k < 3; ++k) {
      const int w = atlas.face_wedge[f][static_cast<size_t>(k)];
      F.vt[static_cast<size_t>(k)] = w;
      if (!set[static_cast<size_t>(w)]) {
        const Vec2& t = layout.wedge_uv[static_cast<size_t>(w)];
        out.texcoords[static_cast<size_t>(w)] = Vec2(t.x() / ps.width, t.y() / ps.height);
        set[static_cast<size_t>(w)] = 1;
      }
    }
  }
}

/// OBJ cannot return to "no material" after a usemtl: when some faces of `out` have a material and
/// some none, the latter get an explicit empty one (appended, "texdefrag_no_material").
void add_no_material(TexturedMesh& out) {
  bool any_material = false, any_none = false;
  for (const Face& F : out.faces) (F.material >= 0 ? any_material : any_none) = true;
  if (any_material && any_none) {
    Material none;
    none.name = "texdefrag_no_material";
    out.materials.push_back(none);
    for (Face& F : out.faces)
      if (F.material < 0) F.material = static_cast<int>(out.materials.size()) - 1;
  }
}

}  // namespace

TexturedMesh make_output_mesh(const TexturedMesh& input, const Atlas& atlas, const Layout& layout,
                              const std::string& stem, const std::string& image_ext,
                              const std::string& output_dir) {
  TexturedMesh out;
  out.positions = input.positions;
  out.colors = input.colors;
  out.normals = input.normals;
  out.groups = input.groups;
  out.materials = input.materials;  // untextured faces keep theirs
  out.faces = input.faces;
  const int first_page_material = static_cast<int>(out.materials.size());
  add_page_materials(input, layout, stem, image_ext, output_dir, out);
  const std::vector<int> remap = drop_unused_materials(input, first_page_material, out);
  assign_texcoords(input, atlas, layout, remap, first_page_material, out);
  add_no_material(out);
  return out;
}

namespace {

// run_pipeline's steps, in the order it runs them. Each writes its figures into the run report.

/// The report's header: version, input, configuration (as given and effective), thread count.
json start_report(const PipelineConfig& config, const RunOptions& options) {
  json report;
  report["texdefrag_version"] = "0.1.0";
  report["input"] = options.input;
  report["config_origin"] = config.origin;
  report["config"] = config.effective;
  report["stages"] = json::object();
  report["threads"] = thread_count();
  return report;
}

/// Refuses a run that would write without an output folder, or into the input's own folder.
void check_output_folder(const RunOptions& options) {
  if (!options.write_output) return;
  if (options.output_dir.empty()) throw StageError("no output folder given");
  const std::string in_dir = canonical_or_absolute(fs::path(options.input).parent_path().empty()
                                                       ? std::string(".")
                                                       : fs::path(options.input).parent_path().string());
  if (canonical_or_absolute(options.output_dir) == in_dir)
    throw StageError("output folder " + options.output_dir + " is the input's folder; choose another so no input file can be overwritten");
}

/// Step "read": reads the input (or takes options.model) into `model`; a missing referenced file
/// is an error unless allow_missing_children, then it is listed in the node.
void read_step(json& report, const ModelFormat& format, const RunOptions& options, const ProgressFn& progress,
               LoadedModel& model) {
  const TexturedMesh& mesh = model.mesh;
  timed(report, "read", [&](json& node) {
    progress("read", 0);
    model = options.model ? *options.model : format.read(options.input);
    node["format"] = format.name();
    if (model.positions_stretched) node["positions_stretched"] = model.positions_stretched;
    if (!model.missing_files.empty()) {
      if (!options.allow_missing_children)
        throw FormatError(model.missing_files.front() +
                          (model.missing_files.size() > 1 ? " (and " + std::to_string(model.missing_files.size() - 1) + " more)" : "") +
                          "; allow_missing_children (--allow-missing-children) processes the file anyway");
      node["missing_files"] = model.missing_files;
    }
    node["faces"] = mesh.faces.size();
    node["positions"] = mesh.positions.size();
    node["texcoords"] = mesh.texcoords.size();
    node["pages"] = mesh.pages.size();
    progress("read", 1);
  });
}

/// The write service of a run that writes its own files (null otherwise): every input file is
/// protected, and the names known now are checked before any stage runs, so a run that would
/// overwrite an input (an MTL the input keeps in the output folder) is refused at once.
std::unique_ptr<OutputSet> open_outputs(const PipelineConfig& config, const RunOptions& options,
                                        const ModelFormat& format, const LoadedModel& model, const std::string& stem) {
  std::unique_ptr<OutputSet> outputs;
  if (options.write_output && !options.write) {  // a write hook writes into its caller's set
    outputs = std::make_unique<OutputSet>(options.output_dir, protected_inputs(config, model), options.input);
    for (const std::string& name : {format.output_name(stem), stem + ".mtl", stem + ".report.json"}) outputs->check(name);
  }
  return outputs;
}

/// The report's "input_stats": faces, untextured faces, topology, charts, UV overlaps, megapixels.
void record_input_stats(json& report, const TexturedMesh& mesh, const Topology& topo, const ChartSet& charts,
                        size_t input_overlaps) {
  size_t untextured = 0;
  for (const Face& f : mesh.faces) untextured += f.page == kNoPage;
  report["input_stats"] = {{"faces", mesh.faces.size()}, {"untextured_faces", untextured},
                           {"topology", topology_summary(topo.report)}, {"charts", chart_summary(charts)},
                           {"uv_overlap_pairs", input_overlaps}};
  double mp = 0;
  for (const Page& p : mesh.pages) mp += static_cast<double>(p.width) * p.height / 1e6;
  report["input_stats"]["megapixels"] = mp;
}

/// Pages deeper than 8 bits per channel are decoded to 8 (docs/io.md "Images"), so their output
/// pages keep 8: said in report["warnings"] (one line naming the first such page) and
/// report["input_stats"]["page_bits_max"], never silently.
void record_page_depth(json& report, const LoadedModel& model) {
  std::vector<uint8_t> used(model.mesh.pages.size(), 0);
  for (const Face& f : model.mesh.faces)
    if (f.page != kNoPage) used[static_cast<size_t>(f.page)] = 1;
  int max_bits = 0;
  size_t deep = 0, first = 0;
  for (size_t p = 0; p < model.page_encodings.size() && p < used.size(); ++p) {
    const int bits = model.page_encodings[p].bits;
    max_bits = std::max(max_bits, bits);
    if (!used[p] || bits <= 8) continue;
    if (deep++ == 0) first = p;
  }
  report["input_stats"]["page_bits_max"] = max_bits;
  if (deep == 0) return;
  report["warnings"].push_back(
      std::to_string(deep) + " input page(s) store more than 8 bits per channel (first: " +
      model.mesh.pages[first].image_path + ", " + std::to_string(model.page_encodings[first].bits) +
      " bits); pages are read at 8 bits per channel (values rounded), so the output pages have 8");
}

/// Runs one stage on ctx and checks its contract (detector: regions a partition; merger: a valid
/// atlas adding no overlap inside a chart; packer: a valid layout adding no overlap). Returns the
/// UV overlap pairs counted after a merger or packer (0 after a detector).
size_t run_and_check(Stage& stage, const std::string& type, StageContext& ctx, size_t input_overlaps) {
  const TexturedMesh& mesh = *ctx.mesh;
  size_t stage_overlaps = 0;
  if (auto* d = dynamic_cast<Detector*>(&stage)) {
    d->detect(ctx);
    check_regions(ctx, type);
  } else if (auto* m = dynamic_cast<Merger*>(&stage)) {
    m->merge(ctx);
    check_atlas(ctx, type);
    // note: checked here as well as after packing, so that an overlap a merger made inside a
    // chart is reported as the merger's, not as the packer's that only moved the chart.
    stage_overlaps = chart_overlap_pairs(mesh, ctx.atlas);
    if (stage_overlaps > input_overlaps)
      throw StageError(type + ": the merged charts overlap themselves in " + std::to_string(stage_overlaps) +
                       " pairs of UV triangles, the input only in " + std::to_string(input_overlaps) +
                       " (no stage may add overlaps)");
  } else if (auto* p = dynamic_cast<Packer*>(&stage)) {
    p->pack(ctx);
    check_layout(ctx, type);
    stage_overlaps = uv_overlap_pairs(mesh, ctx.atlas, &ctx.layout);
    if (stage_overlaps > input_overlaps)
      throw StageError(type + ": the packed charts overlap in " + std::to_string(stage_overlaps) +
                       " pairs of UV triangles, the input only in " + std::to_string(input_overlaps) +
                       " (no stage may add overlaps)");
  }
  return stage_overlaps;
}

/// One configured stage as a timed report node: the stage writes its own numbers into a fresh
/// node; the framework's figures (section, regions / charts / pages, overlaps) are added after the
/// framework checked the stage's contract and that it wrote no reserved key.
void stage_step(json& report, Stage& stage, const StageConfig& sc, StageContext& ctx, size_t input_overlaps) {
  timed(report, sc.type, [&](json& node) {
    json own = json::object();
    ctx.report = &own;
    ctx.step(sc.type, 0);
    const int charts_in = ctx.atlas.num_charts;
    const size_t stage_overlaps = run_and_check(stage, sc.type, ctx, input_overlaps);
    ctx.step(sc.type, 1);
    ctx.report = nullptr;
    check_reserved_keys(own, sc.type);
    for (auto it = own.begin(); it != own.end(); ++it) node[it.key()] = it.value();
    node["section"] = sc.section;
    if (dynamic_cast<Detector*>(&stage)) {
      node["regions"] = ctx.regions.num_regions;
    } else if (dynamic_cast<Merger*>(&stage)) {
      const DistortionSummary d = report_merger_figures(*ctx.mesh, charts_in, ctx.atlas, node);
      check_merger_distortion(sc.type, d, dynamic_cast<Merger&>(stage).distortion_budget());
      node["uv_overlap_pairs"] = stage_overlaps;
    } else {
      node["pages_out"] = ctx.layout.pages.size();
      node["uv_overlap_pairs"] = stage_overlaps;
    }
  });
}

/// The texture section's options as the resampler takes them.
ResampleOptions resample_options(const Options& t) {
  ResampleOptions ro;
  ro.filter = t.get_enum<Filter>("filter", {{"nearest", Filter::Nearest}, {"bilinear", Filter::Bilinear}, {"bicubic", Filter::Bicubic}});
  ro.fill = t.get_enum<GutterFill>("fill", {{"none", GutterFill::None}, {"dilate", GutterFill::Dilate}, {"pull_push", GutterFill::PullPush}});
  ro.dilate_width = static_cast<int>(t.get_int("dilate_width"));
  ro.fill_blocks = t.get_bool("fill_blocks");
  ro.fit = t.get_enum<TexelFit>("fit", {{"sample", TexelFit::Sample}, {"least_squares", TexelFit::LeastSquares}});
  ro.fit_iterations = static_cast<int>(t.get_int("fit_iterations"));
  return ro;
}

/// used[p] = 1 when some face of `mesh` lies on page p (one entry per page).
std::vector<uint8_t> used_pages(const TexturedMesh& mesh) {
  std::vector<uint8_t> used(mesh.pages.size(), 0);
  for (const Face& f : mesh.faces)
    if (f.page != kNoPage) used[static_cast<size_t>(f.page)] = 1;
  return used;
}

/// The pixels of every input page some face uses (the others stay empty), decoded side by side on
/// the framework's threads: each page's pixels depend on its file alone, and a failure is the
/// lowest-numbered failing page's, as when decoded in turn (parallel_for). t016_L19's 24 pages
/// took 0.17 s in turn, one core idle.
std::vector<Image> decode_used_pages(const LoadedModel& model) {
  const TexturedMesh& mesh = model.mesh;
  const std::vector<uint8_t> used = used_pages(mesh);
  std::vector<size_t> todo;
  for (size_t p = 0; p < mesh.pages.size(); ++p)
    if (used[p]) todo.push_back(p);
  std::vector<Image> pages(mesh.pages.size());
  parallel_for(todo.size(), [&](size_t k) { pages[todo[k]] = model.page_image(todo[k]); });
  return pages;
}

/// Largest decoded size (bytes, 4 per pixel) of the used input pages that EarlyPages decodes while
/// the stages run: they are held through the merger and the packer, so big models (the 1M factory:
/// 72 MP) keep decoding at the resampling, under their merger's peak. 64 MiB: t016_L19 (10.7 MP)
/// and the 100k factory (6.3 MP) are inside, each tile's peak stays under the M-method's program.
constexpr size_t kEarlyDecodeMaxBytes = size_t(64) << 20;

/// The input pages some face uses, decoded on a thread of their own while the stages run (with more
/// than one thread, a run that goes on to the resampling and used pages of known size up to
/// kEarlyDecodeMaxBytes), else by decode_used_pages when the resampling asks. The merger's second
/// pass is one queue (docs/speed.md): the second core is mostly idle then, and the decoding
/// (t078_L17 0.09 s, t016_L19 0.17 s of one core, in turn) fits beside it. The pixels depend on the
/// files alone; pages are decoded in turn, so an error is the lowest-numbered failing page's, thrown
/// by take() where the resampling throws it.
class EarlyPages {
 public:
  EarlyPages(const LoadedModel& model, const RunOptions& options) : model_(model) {
    if (thread_count() <= 1 || !options.stop_after.empty()) return;
    size_t bytes = 0;
    const std::vector<uint8_t> used = used_pages(model.mesh);
    for (size_t p = 0; p < used.size(); ++p) {
      const Page& page = model.mesh.pages[p];
      if (!used[p]) continue;
      if (page.width <= 0 || page.height <= 0) return;
      bytes += static_cast<size_t>(page.width) * static_cast<size_t>(page.height) * 4;
    }
    if (bytes == 0 || bytes > kEarlyDecodeMaxBytes) return;
    thread_ = std::thread([this, used] {
      try {
        pages_.resize(used.size());
        for (size_t p = 0; p < used.size(); ++p)
          if (used[p]) pages_[p] = model_.page_image(p);
      } catch (...) {
        error_ = std::current_exception();
      }
    });
  }
  EarlyPages(const EarlyPages&) = delete;
  EarlyPages& operator=(const EarlyPages&) = delete;
  ~EarlyPages() {
    if (thread_.joinable()) thread_.join();
  }

  /// The decoded pages (decoded now when no thread was started); rethrows the thread's error.
  std::vector<Image> take() {
    if (!thread_.joinable()) return decode_used_pages(model_);
    thread_.join();
    if (error_) std::rethrow_exception(error_);
    return std::move(pages_);
  }

 private:
  const LoadedModel& model_;
  std::thread thread_;
  std::vector<Image> pages_;
  std::exception_ptr error_;
};

/// Step "texture.resample": takes the input pages some face uses (`early`), returns the output
/// pages of ctx's atlas and layout.
std::vector<Image> resample_step(json& report, const PipelineConfig& config, const LoadedModel& model,
                                 const StageContext& ctx, const ProgressFn& progress, EarlyPages& early) {
  const TexturedMesh& mesh = model.mesh;
  std::vector<Image> out_pages;
  timed(report, "texture.resample", [&](json& node) {
    const std::vector<Image> in_pages = early.take();
    const ResampleOptions ro = resample_options(config.texture);
    ResampleStats rs;
    out_pages = resample_atlas(mesh, in_pages, ctx.atlas, ctx.layout, ro, &rs, progress);
    node["texels_written"] = rs.texels_written;
    node["texels_copied"] = rs.texels_copied;
    node["faces_copied"] = rs.faces_copied;
    node["faces_resampled"] = rs.faces_resampled;
    node["texels_fitted"] = rs.texels_fitted;
  });
  return out_pages;
}

/// The orientation of the written texture coordinates (ModelFormat::texcoord_read_back): the
/// faces a reader of `file` finds turned over while the output mesh has them right go to the write
/// node (`faces_turned_as_written`, or `"not checked"` when the format cannot say) and, when any,
/// to the report's warnings.
void check_read_back(json& report, json& node, const TexcoordReadBack& read_back, const TexturedMesh& in,
                     const TexturedMesh& out, const std::string& file) {
  if (!read_back) {
    node["faces_turned_as_written"] = "not checked";
    return;
  }
  const size_t turned = faces_turned_by(in, out, read_back);
  node["faces_turned_as_written"] = turned;
  if (turned > 0)
    report["warnings"].push_back(std::to_string(turned) + " face(s) of " + file +
                                 " read back turned over: their texture coordinates, rounded as the format "
                                 "stores them, reverse or collapse their UV triangles (docs/io.md, "
                                 "\"Orientation as written\")");
}

/// Step "write": the output mesh and pages through the format's writer into `outputs` (or through
/// options.write, which writes into its caller's set).
void write_step(json& report, const PipelineConfig& config, const RunOptions& options, const ModelFormat& format,
                const LoadedModel& model, const StageContext& ctx, const std::vector<Image>& out_pages,
                const std::string& stem, OutputSet* outputs) {
  timed(report, "write", [&](json& node) {
    PageWriteOptions po = choose_page_options(model, config.output.get_string("image_format"),
                                              static_cast<int>(config.output.get_int("jpeg_quality")),
                                              config.output.get_bool("match_input_quality"),
                                              config.output.get_string("jpeg_subsampling"),
                                              {config.output.get_string("jpeg_tables") == "flat" ? JpegTables::Flat
                                                                                                 : JpegTables::Standard,
                                               config.output.get_bool("jpeg_progressive")});
    po.output_options = config.output.values();
    JpegQualityFit fit;
    if (config.output.get_string("jpeg_quality_fit") == "input_bytes")
      fit = fit_page_quality(model, out_pages, po, static_cast<int>(config.output.get_int("jpeg_max_quality")));
    const std::string ext = po.format == ImageFormat::Jpeg ? "jpg" : "png";
    TexturedMesh out = make_output_mesh(model.mesh, ctx.atlas, ctx.layout, stem, ext, options.output_dir);
    const WriteResult wr = options.write ? options.write(model, out, out_pages, po)
                                         : format.write(model, out, out_pages, stem, po, *outputs);
    node["format"] = format.name();
    check_read_back(report, node, format.texcoord_read_back(po), model.mesh, out, wr.main_file);
    node["image_format"] = ext == "jpg" ? "jpeg" : "png";
    if (po.format == ImageFormat::Jpeg) {
      node["jpeg_quality"] = po.jpeg_quality;
      node["jpeg_subsampling"] = jpeg_subsampling_name(po.jpeg_subsampling);
      node["jpeg_tables"] = jpeg_tables_name(po.jpeg_coding.tables);
      node["jpeg_progressive"] = po.jpeg_coding.progressive;
      if (po.jpeg_quality_from_input) node["jpeg_quality_estimated"] = po.jpeg_standard_quality;
      if (fit.probes > 0)
        node["jpeg_quality_fit"] = {{"probes", fit.probes},
                                    {"sample_probes", fit.sample_probes},
                                    {"bytes", fit.bytes},
                                    {"within_input_bytes", fit.within_budget}};
    }
    node["file"] = wr.main_file;
    node["page_bytes"] = wr.page_bytes;
    size_t in_bytes = 0;
    for (const PageEncoding& e : model.page_encodings) in_bytes += e.bytes;
    node["input_page_bytes"] = in_bytes;
    for (const auto& kv : wr.report.items()) node[kv.key()] = kv.value();
    report["output"] = wr.main_file;
  });
}

/// The report's totals: wall and CPU time since the run started, and the run's peak memory.
void finish_report(json& report, Clock::time_point t_start, double cpu_start) {
  report["total_time_s"] = seconds_since(t_start);
  report["total_cpu_s"] = process_cpu_seconds() - cpu_start;
  // note: the kernel's peak counter is reset before each stage, so the run's peak is the largest
  // stage peak.
  size_t peak = peak_rss_bytes();
  for (const auto& kv : report["stages"].items())
    if (kv.value().contains("peak_rss_bytes")) peak = std::max(peak, kv.value()["peak_rss_bytes"].get<size_t>());
  report["peak_rss_bytes"] = peak;
}

/// Creates the detector, merger and packer of config in turn and runs each on ctx; false when the
/// run stops after one of them (options.stop_after).
bool run_stages(json& report, const PipelineConfig& config, const RunOptions& options, StageContext& ctx,
                size_t input_overlaps) {
  Registry& reg = Registry::instance();
  const StageConfig* stages[] = {&config.detector, &config.merger, &config.packer};
  for (const StageConfig* sc : stages) {
    auto stage = reg.create(sc->type);
    stage->set_options(sc->options);
    stage_step(report, *stage, *sc, ctx, input_overlaps);
    if (options.on_stage) options.on_stage(sc->section, ctx);
    if (sc->section == options.stop_after) return false;
  }
  return true;
}

/// Records the output's faces, charts, pages and megapixels in report["output_stats"].
void record_output_stats(json& report, const TexturedMesh& mesh, const StageContext& ctx) {
  double mp_out = 0;
  for (const auto& p : ctx.layout.pages) mp_out += static_cast<double>(p.width) * p.height / 1e6;
  report["output_stats"] = {{"faces", mesh.faces.size()},
                            {"charts", ctx.atlas.num_charts},
                            {"pages", ctx.layout.pages.size()},
                            {"megapixels", mp_out}};
}

/// Writes the report (when output.write_report) as the output set's manifest, then commits the set.
void commit_outputs(const PipelineConfig& config, const json& report, const std::string& stem, OutputSet& outputs) {
  // The report is the manifest: written last, so its presence vouches for the set beside it.
  if (config.output.get_bool("write_report")) {
    const std::string path = outputs.manifest_path_for(stem + ".report.json");
    write_file_atomic(path, report.dump(2) + "\n");
  }
  outputs.commit();
}

}  // namespace

json run_pipeline(const PipelineConfig& config, const RunOptions& options) {
  const auto t_start = Clock::now();
  const double cpu_start = process_cpu_seconds();
  json report = start_report(config, options);
  ProgressFn progress = rate_limited(options.progress);

  std::string stem = config.output.get_string("name");
  if (stem.empty()) stem = fs::path(options.input).stem().string();
  check_output_folder(options);

  const ModelFormat& format = options.format ? *options.format : format_for_input(options.input);
  LoadedModel model;
  TexturedMesh& mesh = model.mesh;
  read_step(report, format, options, progress, model);
  std::unique_ptr<OutputSet> outputs = open_outputs(config, options, format, model, stem);
  Topology topo;
  ChartSet charts;
  timed(report, "charts", [&](json& node) {
    topo = build_topology(mesh);
    charts = build_charts(mesh, topo);
    node["topology"] = topology_summary(topo.report);
    node["input"] = chart_summary(charts);
  });
  // note: counted once here; after packing the framework counts again and refuses more.
  const size_t input_overlaps = uv_overlap_pairs(mesh, charts.atlas, nullptr);
  record_input_stats(report, mesh, topo, charts, input_overlaps);
  record_page_depth(report, model);

  StageContext ctx;
  ctx.mesh = &mesh;
  ctx.topology = &topo;
  ctx.input_charts = &charts;
  ctx.atlas = charts.atlas;
  ctx.progress = progress;
  ctx.input_path = options.input;
  ctx.outputs = outputs.get();
  EarlyPages early_pages(model, options);
  if (!run_stages(report, config, options, ctx, input_overlaps)) return report;

  // note: the topology and the input charts serve the stages only; released here, so they do not
  // add to the resampling's peak (input and output pages are held at once there).
  ctx.topology = nullptr;
  ctx.input_charts = nullptr;
  topo = Topology();
  charts = ChartSet();
  ctx.regions = Regions();
  // note: what the stages freed in small pieces stays resident otherwise, beside the resampling's
  // large buffers (fresh pages): 613 -> 157 MiB at its start on the 1M-face factory, its peak 822 ->
  // 695 MiB. Only here: every page given back is faulted in again when reused (CPU time).
  release_free_memory();
  const std::vector<Image> out_pages = resample_step(report, config, model, ctx, progress, early_pages);
  // note: the resampling's input pages and fit windows are free now; given back before the write
  // step, whose page encoding (a progressive JPEG holds every coefficient of its page) is the
  // run's peak on large models.
  release_free_memory();

  record_output_stats(report, mesh, ctx);

  if (options.write_output) write_step(report, config, options, format, model, ctx, out_pages, stem, outputs.get());
  finish_report(report, t_start, cpu_start);
  if (outputs) commit_outputs(config, report, stem, *outputs);
  return report;
}

}  // namespace texdefrag
