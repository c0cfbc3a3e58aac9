// 3D Tiles reader, production driver and structural check (see texdefrag/io/tiles3d.h).
#include "texdefrag/io/tiles3d.h"

#include "texdefrag/io/gltf_format.h"
#include "texdefrag/io/output_set.h"

#include "gltf_internal.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>

namespace fs = std::filesystem;

namespace texdefrag {

using gltf_detail::ojson;

namespace {

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

ojson read_json(const std::string& path, const std::string& parent) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw TilesetError(path + ": tileset not found" + (parent.empty() ? std::string() : " (named by " + parent + ")"));
  try {
    return ojson::parse(in);
  } catch (const std::exception& e) {
    throw TilesetError(path + ": tileset JSON: " + e.what());
  }
}

uint32_t le32(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

std::string lower_ext(const std::string& p) {
  std::string e = fs::path(p).extension().string();
  if (!e.empty()) e.erase(0, 1);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

/// Content URIs of a tile: 1.0 "content", 1.1 "contents".
std::vector<std::string> content_uris(const ojson& tile) {
  std::vector<std::string> out;
  auto one = [&](const ojson& c) {
    if (c.is_object()) {
      if (c.contains("uri")) out.push_back(c["uri"].get<std::string>());
      else if (c.contains("url")) out.push_back(c["url"].get<std::string>());  // pre-1.0 spelling
    }
  };
  if (tile.contains("content")) one(tile["content"]);
  if (tile.contains("contents"))
    for (const auto& c : tile["contents"]) one(c);
  return out;
}

/// The linear part (upper 3x3) of a tile's `transform` (16 numbers, column-major); identity when
/// the tile has none. Throws TilesetError naming the file when it is not 16 finite numbers.
Mat3 tile_linear(const ojson& tile, const std::string& file) {
  Mat3 m = Mat3::Identity();
  if (!tile.contains("transform")) return m;
  const ojson& t = tile["transform"];
  if (!t.is_array() || t.size() != 16) throw TilesetError(file + ": a tile's transform is not an array of 16 numbers");
  for (const auto& x : t)
    if (!x.is_number() || !std::isfinite(x.get<double>()))
      throw TilesetError(file + ": a tile's transform is not an array of 16 finite numbers");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = t[static_cast<size_t>(c * 4 + r)].get<double>();
  return m;
}

/// fn(tile, linear) for every tile, depth first; linear: the product of the transforms' linear
/// parts from `parent` down to and including the tile's own.
void walk_tiles(const ojson& tile, const Mat3& parent, const std::string& file,
                const std::function<void(const ojson&, const Mat3&)>& fn) {
  const Mat3 linear = parent * tile_linear(tile, file);
  fn(tile, linear);
  if (tile.contains("children"))
    for (const auto& c : tile["children"]) walk_tiles(c, linear, file, fn);
}

/// The turn 3D Tiles puts between a glTF content and its tile (glTF is y-up, tiles z-up): a
/// rotation of +90 degrees about x for asset.gltfUpAxis "Y" (the default), -90 degrees about y for
/// "X", none for "Z". Throws TilesetError naming the file for another value.
Mat3 gltf_up_turn(const ojson& tileset, const std::string& file) {
  std::string axis = "Y";
  if (tileset.contains("asset") && tileset["asset"].is_object() && tileset["asset"].contains("gltfUpAxis")) {
    const ojson& a = tileset["asset"]["gltfUpAxis"];
    if (!a.is_string()) throw TilesetError(file + ": asset.gltfUpAxis is not a string");
    axis = a.get<std::string>();
  }
  Mat3 m;
  if (axis == "Y" || axis == "y") m << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  else if (axis == "X" || axis == "x") m << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  else if (axis == "Z" || axis == "z") m = Mat3::Identity();
  else throw TilesetError(file + ": asset.gltfUpAxis '" + axis + "' is not X, Y or Z");
  return m;
}

std::string resolve(const std::string& tileset, const std::string& uri) {
  return (fs::path(tileset).parent_path() / gltf_detail::url_decode(uri)).lexically_normal().string();
}

}  // namespace

bool is_tileset(const std::string& path) {
  if (lower_ext(path) != "json") return false;
  std::ifstream in(path);
  if (!in) return false;
  try {
    const ojson j = ojson::parse(in);
    return j.is_object() && j.contains("asset") && j.contains("root");
  } catch (const std::exception&) {
    return false;
  }
}

Tileset read_tileset(const std::string& path, bool keep_going) {
  Tileset ts;
  ts.path = path;
  const fs::path root = fs::absolute(fs::path(path).parent_path()).lexically_normal();
  std::set<std::string> seen;
  std::function<void(const std::string&, const std::string&, const Mat3&)> visit = [&](const std::string& file,
                                                                                      const std::string& parent,
                                                                                      const Mat3& above) {
    const std::string key = fs::absolute(file).lexically_normal().string();
    if (!seen.insert(key).second) throw TilesetError(file + ": external tileset reached twice (named by " + parent + "): a cycle");
    const ojson j = read_json(file, parent);
    if (!j.is_object() || !j.contains("root") || !j["root"].is_object())
      throw TilesetError(file + ": not a tileset (no \"root\" tile)" + (parent.empty() ? std::string() : " (named by " + parent + ")"));
    ts.tilesets.push_back(file);
    const Mat3 up = gltf_up_turn(j, file);
    auto tile_contents = [&](const ojson& tile, const Mat3& linear) {
      if (tile.contains("implicitTiling") || (tile.contains("extensions") && tile["extensions"].contains("3DTILES_implicit_tiling")))
        throw TilesetError(file + ": implicit tiling is not supported");
      for (const std::string& uri : content_uris(tile)) {
        if (uri.find("://") != std::string::npos) throw TilesetError(file + ": content '" + uri + "' is not a local file");
        const std::string p = resolve(file, uri);
        const fs::path rel = fs::absolute(p).lexically_normal().lexically_relative(root);
        if (rel.empty() || *rel.begin() == "..")
          throw TilesetError(file + ": content '" + uri + "' lies outside " + root.string() + " (the output mirrors that folder)");
        std::error_code ec;
        if (!fs::is_regular_file(p, ec)) {
          const std::string error = p + ": content not found (named by " + file + ")";
          if (!keep_going) throw TilesetError(error);
          ts.broken.push_back({p, file, error});
          continue;
        }
        const std::string e = lower_ext(p);
        if (e == "json") {
          // keep_going: an external tileset that fails leaves nothing of its subtree behind.
          const size_t n_tilesets = ts.tilesets.size(), n_contents = ts.contents.size(), n_broken = ts.broken.size();
          try {
            visit(p, file, linear);
          } catch (const TilesetError& err) {
            if (!keep_going) throw;
            ts.tilesets.resize(n_tilesets);
            ts.contents.resize(n_contents);
            ts.broken.resize(n_broken);
            ts.broken.push_back({p, file, err.what()});
          }
          continue;
        }
        ts.contents.push_back({uri, p, file, e, linear * up});
      }
    };
    try {
      walk_tiles(j["root"], above, file, tile_contents);
    } catch (const nlohmann::json::exception& e) {
      // note: a member of another JSON type ("uri": 5, "children": "x") makes the JSON library
      // throw; the error names the tileset like every other (found by fuzz_tiles3d).
      throw TilesetError(file + ": tileset JSON: " + e.what());
    }
  };
  visit(path, "", Mat3::Identity());
  return ts;
}

B3dm parse_b3dm(const std::vector<uint8_t>& b, const std::string& where) {
  if (b.size() < 28 || std::memcmp(b.data(), "b3dm", 4) != 0) throw TilesetError(where + ": not a b3dm (bad magic or shorter than its header)");
  const uint32_t version = le32(&b[4]), length = le32(&b[8]);
  if (version != 1) throw TilesetError(where + ": b3dm version " + std::to_string(version) + " (expected 1)");
  if (length != b.size())
    throw TilesetError(where + ": b3dm header says " + std::to_string(length) + " bytes, the file has " + std::to_string(b.size()));
  const uint32_t ftj = le32(&b[12]), ftb = le32(&b[16]), btj = le32(&b[20]), btb = le32(&b[24]);
  // note: legacy headers (batchLength first) make one of these huge; Cesium tests >= 570425344.
  if (btj >= 570425344u || btb >= 570425344u) throw TilesetError(where + ": legacy b3dm header is not supported");
  const uint64_t tables = uint64_t(ftj) + ftb + btj + btb;
  if (28 + tables > b.size()) throw TilesetError(where + ": b3dm tables run past the end of the file");
  B3dm r;
  size_t at = 28;
  auto take = [&](uint32_t n) {
    std::string s(reinterpret_cast<const char*>(&b[at]), n);
    at += n;
    return s;
  };
  r.feature_table_json = take(ftj);
  r.feature_table_binary = take(ftb);
  r.batch_table_json = take(btj);
  r.batch_table_binary = take(btb);
  r.glb.assign(b.begin() + static_cast<std::ptrdiff_t>(at), b.end());
  // Padding after the GLB (to 8 bytes) is not part of it: cut to the GLB's own length.
  if (r.glb.size() >= 12 && std::memcmp(r.glb.data(), "glTF", 4) == 0 && le32(&r.glb[8]) <= r.glb.size()) r.glb.resize(le32(&r.glb[8]));
  return r;
}

std::string write_b3dm(const B3dm& b) {
  std::string glb(b.glb.begin(), b.glb.end());
  const size_t head = 28 + b.feature_table_json.size() + b.feature_table_binary.size() + b.batch_table_json.size() +
                      b.batch_table_binary.size();
  while ((head + glb.size()) % 8) glb.push_back('\0');
  std::string out = "b3dm";
  auto put32 = [&](size_t v) {
    for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
  };
  put32(1);
  put32(head + glb.size());
  put32(b.feature_table_json.size());
  put32(b.feature_table_binary.size());
  put32(b.batch_table_json.size());
  put32(b.batch_table_binary.size());
  out += b.feature_table_json + b.feature_table_binary + b.batch_table_json + b.batch_table_binary + glb;
  return out;
}

namespace {

/// Relative name of `file` under `root` (with '/').
std::string rel_name(const std::string& file, const fs::path& root) {
  return fs::absolute(file).lexically_normal().lexically_relative(root).generic_string();
}

/// A tileset JSON for the output: the same bytes, unless its 3DTILES_content_gltf lists name
/// extensions that no output content uses any more (KTX2 pages become JPEG/PNG, Draco may go).
std::string output_tileset_json(const std::string& path, const std::set<std::string>& gone) {
  const std::vector<uint8_t> bytes = read_bytes(path);
  ojson j = ojson::parse(bytes.begin(), bytes.end());
  bool changed = false;
  if (j.contains("extensions") && j["extensions"].contains("3DTILES_content_gltf")) {
    ojson& ext = j["extensions"]["3DTILES_content_gltf"];
    for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
      if (!ext.contains(list)) continue;
      ojson kept = ojson::array();
      for (const auto& e : ext[list])
        if (!gone.count(e.get<std::string>())) kept.push_back(e);
      if (kept.size() != ext[list].size()) {
        changed = true;
        if (kept.empty()) ext.erase(list);
        else ext[list] = kept;
      }
    }
  }
  return changed ? j.dump(4) + "\n" : std::string(bytes.begin(), bytes.end());
}

}  // namespace

TilesetPlan plan_tileset(const std::string& path, bool keep_going) {
  TilesetPlan plan;
  plan.tileset = read_tileset(path, keep_going);
  const fs::path root = fs::absolute(fs::path(path).parent_path()).lexically_normal();
  std::vector<GltfInput> inputs;
  std::vector<const TilesetContent*> input_content;
  for (const TilesetContent& c : plan.tileset.contents) {
    if (c.kind == "glb" || c.kind == "gltf") {
      inputs.push_back({c.path, {}, ""});
    } else if (c.kind == "b3dm") {
      try {
        B3dm b = parse_b3dm(read_bytes(c.path), c.path + " (named by " + c.tileset + ")");
        inputs.push_back({c.path, std::move(b.glb), fs::path(c.path).parent_path().string()});
      } catch (const TilesetError&) {
        inputs.push_back({c.path, {}, ""});  // unreadable: a model of its own, whose run reports the error
      }
    } else {
      plan.copies.push_back(rel_name(c.path, root));
      continue;
    }
    input_content.push_back(&c);
  }
  std::vector<std::vector<size_t>> groups;
  std::vector<std::vector<std::string>> images;
  std::vector<std::string> unreadable;  // their models fail when run, naming the file
  try {
    groups = gltf_shared_image_groups(inputs, &images, &unreadable);
  } catch (const GltfError& e) {
    throw TilesetError(std::string(e.what()));
  }
  for (const std::vector<size_t>& g : groups) {
    TilesetModel m;
    m.parent = input_content[g.front()]->tileset;
    for (size_t i : g) {
      m.contents.push_back(rel_name(inputs[i].path, root));
      m.files.push_back(fs::absolute(inputs[i].path).lexically_normal().string());
    }
    for (size_t i : g)
      for (const std::string& f : images[i])
        if (std::find(m.files.begin(), m.files.end(), f) == m.files.end()) m.files.push_back(f);
    plan.models.push_back(std::move(m));
  }
  return plan;
}

namespace {

/// The models of `plan` that `wanted` selects (all when empty); TilesetError when a name is not a
/// glTF/b3dm content of the tileset or a model is named only in part.
std::vector<size_t> selected_models(const TilesetPlan& plan, const std::vector<std::string>& wanted) {
  std::vector<size_t> out;
  if (wanted.empty()) {
    for (size_t m = 0; m < plan.models.size(); ++m) out.push_back(m);
    return out;
  }
  const std::set<std::string> want(wanted.begin(), wanted.end());
  std::set<std::string> found;
  for (size_t m = 0; m < plan.models.size(); ++m) {
    const auto& cs = plan.models[m].contents;
    const size_t named = static_cast<size_t>(std::count_if(cs.begin(), cs.end(), [&](const std::string& c) { return want.count(c) > 0; }));
    if (named == 0) continue;
    if (named != cs.size()) {
      std::string all;
      for (const std::string& c : cs) all += (all.empty() ? "" : ", ") + c;
      throw TilesetError(plan.tileset.path + ": contents " + all + " share an atlas and are one model: name all of them");
    }
    found.insert(cs.begin(), cs.end());
    out.push_back(m);
  }
  const fs::path root = fs::absolute(fs::path(plan.tileset.path).parent_path()).lexically_normal();
  for (const std::string& w : want) {
    if (found.count(w)) continue;
    for (const TilesetBroken& b : plan.tileset.broken)
      if (rel_name(b.path, root) == w) throw TilesetError(b.error);
    throw TilesetError(plan.tileset.path + ": '" + w + "' is not a glTF or b3dm content of this tileset");
  }
  return out;
}

/// The inputs of one model of a tileset: a GltfInput per content (a b3dm's GLB taken out of it),
/// each with the measure_linear of its content in `linear_of` (when listed).
struct ModelInputs {
  std::vector<GltfInput> group;
  std::vector<B3dm> b3dms;            // per content: its b3dm (empty for glTF/GLB)
  std::vector<const B3dm*> b3dm_of;  // per content: into b3dms, or null for glTF/GLB
};

/// Reads the b3dm contents of `model` (names relative to `root`) and lists every content's input.
/// Throws naming the content and its tileset when a b3dm is malformed.
ModelInputs model_inputs(const TilesetModel& model, const fs::path& root, const std::map<std::string, Mat3>& linear_of) {
  const std::vector<std::string>& names = model.contents;
  ModelInputs in;
  in.b3dms.resize(names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string path = (root / names[i]).string();
    if (lower_ext(path) == "b3dm") {
      in.b3dms[i] = parse_b3dm(read_bytes(path), path + " (content of " + model.parent + ")");
      in.group.push_back({path, in.b3dms[i].glb, fs::path(path).parent_path().string()});
      in.b3dm_of.push_back(&in.b3dms[i]);
    } else {
      in.group.push_back({path, {}, ""});
      in.b3dm_of.push_back(nullptr);
    }
    const auto lin = linear_of.find(names[i]);
    if (lin != linear_of.end()) in.group.back().outer_linear = lin->second;
  }
  return in;
}

/// RunOptions::write for one model of a tileset: builds its documents with `format`, writes each
/// content `names[i]` (wrapped again in its b3dm tables when b3dm_of[i]) and the shared files into
/// `files`, and adds to `still_used` the extensions a written document still names.
WriteResult write_model_contents(const GltfFormat& format, const LoadedModel& lm, const TexturedMesh& out,
                                 const std::vector<Image>& pages, const PageWriteOptions& po,
                                 const std::vector<std::string>& names, const std::vector<const B3dm*>& b3dm_of,
                                 OutputSet& files, std::set<std::string>& still_used) {
  const GltfOutput go = format.build(lm, out, pages, names, po);
  WriteResult wr;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& doc = go.documents[i];
    for (const char* e : {"KHR_texture_basisu", "KHR_draco_mesh_compression"})
      if (doc.find(e) != std::string::npos) still_used.insert(e);
    if (b3dm_of[i]) {
      B3dm nb = *b3dm_of[i];
      nb.glb.assign(doc.begin(), doc.end());
      files.write_file(names[i], write_b3dm(nb));
    } else {
      files.write_file(names[i], doc);
    }
    wr.files.push_back(files.final_path(names[i]));
  }
  for (const auto& f : go.files) {
    files.write_file(f.path, f.bytes);
    wr.files.push_back(files.final_path(f.path));
  }
  wr.main_file = wr.files.front();
  wr.page_bytes = go.report.value("page_bytes", size_t{0});
  wr.report = go.report;
  return wr;
}

/// The summary line of one model (contents `names`, run report `report` written as report_name)
/// in `<tileset stem>.summary.json`; pin, pout: its page bytes in and out.
nlohmann::json model_summary(const std::vector<std::string>& names, const std::string& report_name,
                             const nlohmann::json& report, size_t pin, size_t pout) {
  nlohmann::json m = {{"contents", names},
                      {"report", report_name},
                      {"faces", report["input_stats"]["faces"]},
                      {"charts_in", report["input_stats"]["charts"]["charts"]},
                      {"charts_out", report["output_stats"]["charts"]},
                      {"megapixels_in", report["input_stats"]["megapixels"]},
                      {"megapixels_out", report["output_stats"]["megapixels"]},
                      {"page_bytes_in", pin},
                      {"page_bytes_out", pout},
                      {"time_s", report["total_time_s"]}};
  if (report.contains("warnings")) m["warnings"] = report["warnings"];
  return m;
}

/// A whole run's last files: the contents copied unchanged, every tileset JSON (naming no more the
/// extensions no written document uses, i.e. those not in still_used) and the summary.
void write_tileset_files(const TilesetPlan& plan, const fs::path& root, const std::string& tileset,
                         const std::set<std::string>& still_used, nlohmann::json& summary, OutputSet& files) {
  summary["copied_unchanged"] = plan.copies;
  for (const std::string& c : plan.copies) {
    const std::vector<uint8_t> b = read_bytes((root / c).string());
    files.write_file(c, std::string(b.begin(), b.end()));
  }
  std::set<std::string> gone;
  for (const char* e : {"KHR_texture_basisu", "KHR_draco_mesh_compression"})
    if (!still_used.count(e)) gone.insert(e);
  for (const std::string& t : plan.tileset.tilesets) files.write_file(rel_name(t, root), output_tileset_json(t, gone));
  files.write_file(fs::path(tileset).stem().string() + ".summary.json", summary.dump(2) + "\n");
}

}  // namespace

nlohmann::json run_tileset(const PipelineConfig& config, const TilesetRunOptions& options) {
  // note: one model at a time (batch tasks) reads past broken parts of the tree that are not its own;
  // a whole run stops at the first (nothing is written, so a partial tileset never looks complete).
  const TilesetPlan plan = plan_tileset(options.tileset, !options.contents.empty());
  const Tileset& ts = plan.tileset;
  const fs::path root = fs::absolute(fs::path(options.tileset).parent_path()).lexically_normal();
  const std::vector<size_t> models = selected_models(plan, options.contents);
  const bool whole = options.contents.empty();
  // note: the whole input folder is protected: no output may land inside the production read.
  OutputSet files(options.output_dir, {root.string()}, options.tileset);
  const GltfFormat format;
  nlohmann::json summary = {{"tileset", options.tileset}, {"config_origin", config.origin}, {"models", nlohmann::json::array()}};
  if (!whole) summary["reports"] = nlohmann::json::array();
  std::map<std::string, Mat3> linear_of;  // content (relative name) -> its measure_linear, first tile naming it
  for (const TilesetContent& c : ts.contents) linear_of.emplace(rel_name(c.path, root), c.measure_linear);
  std::set<std::string> still_used;
  size_t in_bytes = 0, out_bytes = 0, faces = 0;
  for (size_t k = 0; k < models.size(); ++k) {
    const TilesetModel& model = plan.models[models[k]];
    const std::vector<std::string>& names = model.contents;
    const ModelInputs inputs = model_inputs(model, root, linear_of);
    if (options.progress) options.progress("tileset " + names.front(), double(k) / double(models.size()));
    RunOptions ro;
    ro.input = inputs.group.front().path;
    ro.output_dir = options.output_dir;
    ro.format = &format;
    try {
      ro.model = std::make_shared<LoadedModel>(format.read_group(inputs.group, root.string()));
    } catch (const std::exception& e) {
      throw TilesetError(std::string(e.what()) + " (content of " + model.parent + ")");
    }
    ro.write = [&](const LoadedModel& lm, const TexturedMesh& out, const std::vector<Image>& pages, const PageWriteOptions& po) {
      return write_model_contents(format, lm, out, pages, po, names, inputs.b3dm_of, files, still_used);
    };
    nlohmann::json report;
    try {
      report = run_pipeline(config, ro);
    } catch (const std::exception& e) {
      throw TilesetError(names.front() + " (content of " + model.parent + "): " + e.what());
    }
    const std::string report_name = (fs::path(names.front()).parent_path() / (fs::path(names.front()).stem().string() + ".report.json")).generic_string();
    files.write_file(report_name, report.dump(2) + "\n");
    const auto& w = report["stages"]["write"];
    const size_t pin = w.value("input_page_bytes", size_t{0}), pout = w.value("page_bytes", size_t{0});
    in_bytes += pin;
    out_bytes += pout;
    faces += report["input_stats"]["faces"].get<size_t>();
    summary["models"].push_back(model_summary(names, report_name, report, pin, pout));
    if (!whole) summary["reports"].push_back(report);
  }
  summary["tilesets"] = ts.tilesets.size();
  summary["contents"] = ts.contents.size();
  summary["faces"] = faces;
  summary["page_bytes_in"] = in_bytes;
  summary["page_bytes_out"] = out_bytes;
  if (whole) write_tileset_files(plan, root, options.tileset, still_used, summary, files);
  files.commit();
  return summary;
}

std::vector<std::string> finish_tileset(const std::string& tileset, const std::string& output_dir) {
  const TilesetPlan plan = plan_tileset(tileset);
  const fs::path root = fs::absolute(fs::path(tileset).parent_path()).lexically_normal();
  std::set<std::string> still_used;
  for (const TilesetModel& m : plan.models)
    for (const std::string& c : m.contents) {
      const std::string out = (fs::path(output_dir) / c).string();
      std::error_code ec;
      if (!fs::is_regular_file(out, ec))
        throw TilesetError(out + ": output of content " + c + " (named by " + m.parent + ") is missing: run its model first");
      const std::vector<uint8_t> b = read_bytes(out);
      const std::string doc(b.begin(), b.end());
      for (const char* e : {"KHR_texture_basisu", "KHR_draco_mesh_compression"})
        if (doc.find(e) != std::string::npos) still_used.insert(e);
    }
  OutputSet files(output_dir, {root.string()}, tileset);
  std::vector<std::string> written;
  for (const std::string& c : plan.copies) {
    const std::vector<uint8_t> b = read_bytes((root / c).string());
    files.write_file(c, std::string(b.begin(), b.end()));
    written.push_back(c);
  }
  std::set<std::string> gone;
  for (const char* e : {"KHR_texture_basisu", "KHR_draco_mesh_compression"})
    if (!still_used.count(e)) gone.insert(e);
  for (const std::string& t : plan.tileset.tilesets) {
    files.write_file(rel_name(t, root), output_tileset_json(t, gone));
    written.push_back(rel_name(t, root));
  }
  files.commit();
  return written;
}

}  // namespace texdefrag
