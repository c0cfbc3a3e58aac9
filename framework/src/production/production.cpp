// Productions: folders of tiles run with one configuration (see texdefrag/production/production.h).
#include "texdefrag/production/production.h"

#include "texdefrag/io/model_format.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/io/osgb.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <regex>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

bool is_image_ext(const std::string& e) {
  static const char* kImages[] = {"jpg", "jpeg", "png", "tif", "tiff", "bmp", "tga"};
  return std::find(std::begin(kImages), std::end(kImages), e) != std::end(kImages);
}

/// "L16" for ContextCapture level files (`..._L16_0uu.osgb`), "root" for `Tile_X/Tile_X.osgb`.
std::string level_of(const fs::path& rel) {
  static const std::regex kLevel("_L([0-9]+)_");
  std::smatch m;
  const std::string name = rel.filename().string();
  if (std::regex_search(name, m, kLevel)) return "L" + m[1].str();
  if (rel.has_parent_path() && rel.parent_path().filename() == rel.stem()) return "root";
  return "";
}

std::string canonical_or_absolute(const std::string& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  return ec ? fs::absolute(p).lexically_normal().string() : c.string();
}

}  // namespace

bool is_production(const std::string& input) {
  std::error_code ec;
  return fs::is_directory(input, ec);
}

Production list_production(const std::string& input, const std::string& output_dir) {
  Production p;
  p.root = input;
  std::error_code ec;
  const bool cc = fs::is_regular_file(fs::path(input) / "metadata.xml", ec);
  p.kind = cc ? "contextcapture" : "obj_folder";
  std::vector<fs::path> files;
  for (auto it = fs::recursive_directory_iterator(input, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file()) files.push_back(fs::relative(it->path(), input));
  if (ec) throw FormatError(input + ": cannot list the folder: " + ec.message());
  std::sort(files.begin(), files.end());
  // ContextCapture ships its productions as OSGB or as OBJ, both with metadata.xml: the tiles are
  // the .osgb files when there are any, else the .obj files.
  const bool has_osgb = std::any_of(files.begin(), files.end(),
                                    [](const fs::path& f) { return lower_extension(f.string()) == "osgb"; });
  const std::string task_ext = cc && has_osgb ? "osgb" : "obj";
  const bool obj_tiles = task_ext == "obj";
  bool tileset = false;
  for (const fs::path& rel : files) {
    const std::string e = lower_extension(rel.string());
    if (e == task_ext) {
      ProductionTask t;
      t.input = (fs::path(input) / rel).string();
      t.relative = rel.generic_string();
      t.output_dir = output_dir.empty() ? "" : (fs::path(output_dir) / rel.parent_path()).lexically_normal().string();
      t.stem = rel.stem().string();
      t.level = level_of(rel);
      p.tasks.push_back(t);
    } else if (!obj_tiles || !(e == "mtl" || is_image_ext(e))) {
      p.copies.push_back(rel.generic_string());
    }
    tileset = tileset || rel.filename() == "tileset.json";
  }
  if (p.tasks.empty()) {
    if (tileset)
      throw FormatError(input + ": a 3D Tiles production (tileset.json) is run by io/tiles3d.h (run_tileset; "
                        "`texdefrag run` and `texdefrag tasks` take the folder or its tileset JSON), not as a folder of tiles");
    throw FormatError(input + ": no " + task_ext + " tile in this folder" +
                      (cc ? " (a ContextCapture production: metadata.xml with Tile_*/ folders of .osgb or .obj files)"
                          : " (expected .obj tiles, or a metadata.xml and .osgb tiles)"));
  }
  return p;
}

json production_json(const Production& p) {
  json tasks = json::array();
  for (const ProductionTask& t : p.tasks)
    tasks.push_back({{"input", t.input}, {"relative", t.relative}, {"output_dir", t.output_dir}, {"stem", t.stem},
                     {"level", t.level}});
  return {{"kind", p.kind}, {"root", p.root}, {"tasks", tasks}, {"copies", p.copies}};
}

namespace {

size_t textured_faces(const TexturedMesh& m) {
  size_t n = 0;
  for (const Face& f : m.faces) n += f.page != kNoPage;
  return n;
}

/// One summary row from a tile's run report.
json task_row(const ProductionTask& t, const json& report) {
  const json& w = report["stages"].value("write", json::object());
  return {{"relative", t.relative},
          {"level", t.level},
          {"faces", report["input_stats"]["faces"]},
          {"charts_in", report["input_stats"]["charts"]["charts"]},
          {"charts_out", report["output_stats"]["charts"]},
          {"megapixels_in", report["input_stats"]["megapixels"]},
          {"megapixels_out", report["output_stats"]["megapixels"]},
          {"page_bytes_in", w.value("input_page_bytes", 0)},
          {"page_bytes_out", w.value("page_bytes", 0)},
          {"image_format", w.value("image_format", "")},
          {"missing_files", report["stages"]["read"].value("missing_files", json::array()).size()},
          {"time_s", report["total_time_s"]},
          {"copied", false}};
}

/// Totals of the rows per level (and "all"); failed tasks are counted, not summed.
json level_totals(const json& rows) {
  std::map<std::string, json> by;
  for (const json& r : rows) {
    for (const std::string& key : {r["level"].get<std::string>(), std::string("all")}) {
      json& t = by[key];
      if (t.is_null())
        t = {{"tasks", 0}, {"failed", 0}, {"faces", 0}, {"charts_in", 0}, {"charts_out", 0}, {"megapixels_in", 0.0},
             {"megapixels_out", 0.0}, {"page_bytes_in", 0}, {"page_bytes_out", 0}, {"time_s", 0.0}};
      t["tasks"] = t["tasks"].get<long>() + 1;
      if (r["status"] == "failed") t["failed"] = t["failed"].get<long>() + 1;
      if (r["status"] == "failed" || r["copied"].get<bool>()) continue;
      for (const char* k : {"faces", "charts_in", "charts_out", "page_bytes_in", "page_bytes_out"})
        t[k] = t[k].get<long>() + r[k].get<long>();
      for (const char* k : {"megapixels_in", "megapixels_out", "time_s"}) t[k] = t[k].get<double>() + r[k].get<double>();
    }
  }
  json out = json::object();
  for (auto& [k, v] : by) out[k.empty() ? "-" : k] = v;
  return out;
}

/// Copies `from` to `to` under a temporary name in to's folder, then renames it: `to` is never
/// partly written. Throws FormatError naming both files.
void copy_into(const std::string& from, const std::string& to) {
  std::error_code ec;
  fs::create_directories(fs::path(to).parent_path(), ec);
  const fs::path tmp = fs::path(to).parent_path() / ("." + fs::path(to).filename().string() + ".tmp-" +
                                                     std::to_string(::getpid()));
  if (!ec) fs::copy_file(from, tmp, fs::copy_options::overwrite_existing, ec);
  if (!ec) fs::rename(tmp, to, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw FormatError(to + ": cannot copy " + from + " there: " + ec.message());
  }
}

/// " (a child of P1, P2)" naming the OSGB files that name `input` as a PagedLOD/ProxyNode child
/// (io/osgb.h osgb_parents), "" for other formats or a file no other names.
std::string parents_of(const std::string& input) {
  if (lower_extension(input) != "osgb") return "";
  std::string out;
  for (const std::string& p : osgb_parents(input)) out += (out.empty() ? " (a child of " : ", ") + p;
  return out.empty() ? out : out + ")";
}

/// Runs one task: a tile with no textured face is copied, any other runs the pipeline. Returns
/// its summary row (status "ok"); throws what the reader or the pipeline threw.
json run_task(const PipelineConfig& config, const ProductionTask& t, const ProductionRunOptions& options, json& report) {
  const ModelFormat& format = format_for_input(t.input);
  auto probe = std::make_shared<LoadedModel>(format.read(t.input));
  if (textured_faces(probe->mesh) == 0) {
    copy_into(t.input, (fs::path(t.output_dir) / fs::path(t.input).filename()).string());
    return {{"relative", t.relative}, {"level", t.level}, {"status", "ok"}, {"copied", true},
            {"faces", probe->mesh.faces.size()}};
  }
  RunOptions ro;
  ro.input = t.input;
  ro.output_dir = t.output_dir;
  ro.progress = options.progress;
  ro.allow_missing_children = options.allow_missing_children;
  ro.model = std::move(probe);  // read once: the pipeline takes the model read here
  ro.format = &format;
  report = run_pipeline(config, ro);
  json row = task_row(t, report);
  row["status"] = "ok";
  return row;
}

}  // namespace

json run_production(const PipelineConfig& config, const Production& production, const ProductionRunOptions& options) {
  if (options.output_dir.empty()) throw FormatError(production.root + ": no output folder given");
  const std::string in_c = canonical_or_absolute(production.root), out_c = canonical_or_absolute(options.output_dir);
  if (out_c == in_c || out_c.rfind(in_c + "/", 0) == 0)
    throw FormatError(options.output_dir + ": the output folder is the production folder or inside it; choose another");
  if (!config.output.get_string("name").empty())
    throw ConfigError({"output.name: a production keeps each tile's own file name; leave output.name empty"});
  json rows = json::array();
  size_t failed = 0;
  for (size_t i = 0; i < production.tasks.size(); ++i) {
    const ProductionTask& t = production.tasks[i];
    if (t.output_dir.empty()) throw FormatError(t.input + ": task without output folder");
    json row, report;
    try {
      row = run_task(config, t, options, report);
    } catch (const ConfigError&) {
      throw;  // the configuration is wrong for every tile: nothing to go on with
    } catch (const std::exception& e) {
      // note: the tile's OutputSet was not committed, so none of its files appeared; the others go on.
      ++failed;
      row = {{"relative", t.relative}, {"level", t.level}, {"status", "failed"}, {"copied", false},
             {"error", "production task " + std::to_string(i + 1) + "/" + std::to_string(production.tasks.size()) +
                           " (" + t.relative + "): " + e.what() + parents_of(t.input)}};
    }
    if (options.on_task) options.on_task(i, t, row, report);
    rows.push_back(row);
  }
  for (const std::string& c : production.copies)
    copy_into((fs::path(production.root) / c).string(), (fs::path(options.output_dir) / c).string());
  json summary = {{"texdefrag_version", "0.1.0"},
                  {"production", production.root},
                  {"kind", production.kind},
                  {"config", config.effective},
                  {"copied", production.copies},
                  {"failed", failed},
                  {"tasks", rows},
                  {"levels", level_totals(rows)}};
  write_file_atomic((fs::path(options.output_dir) / "texdefrag_summary.json").string(), summary.dump(2) + "\n");
  return summary;
}

}  // namespace texdefrag
