// `texdefrag tasks` and `texdefrag batch` (docs/batch.md).
//
// tasks: the task list of a production, as JSON: one task per tile file and level, a task being
//        "run texdefrag on one input file, write its outputs into one output folder". This is the
//        one place that knows how a production is laid out; the batch driver only reads the list.
// batch: runs a task list in parallel processes or on a Dask cluster with a journal. The driver
//        is Python (tools/batch/texdefrag_batch): Dask's client, SQLite and process supervision
//        are Python's standard ground, and the workers only ever exec this executable. This
//        command execs `python -m texdefrag_batch --texdefrag <this executable> ARGS...`.
#include "commands.h"

#include "texdefrag/io/model_format.h"
#include "texdefrag/io/tiles3d.h"
#include "texdefrag/production/production.h"
#include "texdefrag/util/paths.h"

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace texdefrag::cli {
namespace {

/// True when a built-in model format reads `p` (io/model_format.h: OBJ today, more as they land).
bool is_model(const fs::path& p) {
  for (const ModelFormat* f : model_formats())
    if (f->can_read(p.string())) return true;
  return false;
}

std::string format_names() {
  std::string s;
  for (const ModelFormat* f : model_formats()) s += (s.empty() ? "" : ", ") + f->name();
  return s;
}

fs::path normal_absolute(const fs::path& p) { return fs::absolute(p).lexically_normal(); }

bool is_under(const fs::path& path, const fs::path& dir) {
  const std::string p = normal_absolute(path).generic_string(), d = normal_absolute(dir).generic_string();
  return p == d || (p.size() > d.size() && p.compare(0, d.size(), d) == 0 && (d.back() == '/' || p[d.size()] == '/'));
}

/// One task: the input file, its id (path relative to the production root without extension,
/// '/'-separated, unique) and the output folder relative to the output root (the input's folder
/// relative to the production root, so the output has the production's layout).
/// The level of a tile file named the ContextCapture way (`Tile_+000_+016_L19_0uuuu1.osgb` -> 19);
/// null when the name has no `_L<digits>` followed by '_' or the end of the stem.
json level_of(const std::string& stem) {
  for (size_t i = stem.find("_L"); i != std::string::npos; i = stem.find("_L", i + 1)) {
    size_t j = i + 2;
    while (j < stem.size() && std::isdigit(static_cast<unsigned char>(stem[j]))) ++j;
    if (j > i + 2 && j - i - 2 < 4 && (j == stem.size() || stem[j] == '_')) return std::stoi(stem.substr(i + 2, j - i - 2));
  }
  return nullptr;
}

json make_task(const fs::path& root, const fs::path& file) {
  const fs::path rel = file.lexically_relative(root);
  fs::path id = rel;
  id.replace_extension();
  const std::string dir = rel.parent_path().generic_string();
  return {{"id", id.generic_string()},
          {"input", normal_absolute(file).string()},
          {"output_dir", dir.empty() ? "." : dir},
          {"tile", dir.empty() ? id.generic_string() : dir},
          {"level", level_of(file.stem().string())}};
}

/// Every model file under `root` that a built-in format reads (recursively, sorted by path), except
/// hidden folders, files under `exclude` and texdefrag outputs (a model with its <stem>.report.json
/// beside it).
json folder_tasks(const fs::path& root, const fs::path& exclude) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end;
       it != end; it.increment(ec)) {
    if (ec) break;
    const fs::path p = it->path();
    if (it->is_directory(ec)) {
      if (p.filename().string().front() == '.' || (!exclude.empty() && is_under(p, exclude)))
        it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file(ec) || !is_model(p)) continue;
    if (fs::exists(p.parent_path() / (p.stem().string() + ".report.json"))) continue;
    files.push_back(p);
  }
  if (ec) throw std::runtime_error("cannot list " + root.string() + ": " + ec.message());
  std::sort(files.begin(), files.end());
  json tasks = json::array();
  for (const auto& f : files) tasks.push_back(make_task(root, f));
  return tasks;
}

/// A 3D Tiles tileset (io/tiles3d.h): one task per model (the contents sharing an atlas stay one
/// task), run as `texdefrag run TILESET --contents C...`; outputs keep their paths relative to the
/// tileset's folder (output_dir "."). The tileset JSONs and the other contents are written by
/// `finish` once every task is finished (their 3DTILES_content_gltf lists depend on the outputs).
json tileset_tasks(const fs::path& tileset) {
  const TilesetPlan plan = plan_tileset(tileset.string(), /*keep_going=*/true);
  const fs::path root = normal_absolute(tileset.parent_path().empty() ? fs::path(".") : tileset.parent_path());
  json out = {{"input", normal_absolute(tileset).string()}, {"root", root.string()}, {"kind", "tileset"},
              {"copies", json::array()}, {"tasks", json::array()},
              {"finish", {"tasks", normal_absolute(tileset).string(), "--finish"}}};
  std::set<std::string> ids;
  for (const TilesetModel& m : plan.models) {
    const fs::path first(m.contents.front());
    std::string id = (first.parent_path() / first.stem()).generic_string();
    if (!ids.insert(id).second) id = first.generic_string();  // a.glb and a.b3dm side by side
    ids.insert(id);
    json args = json::array();
    for (const std::string& c : m.contents) {
      args.push_back("--contents");
      args.push_back(c);
    }
    json files = json::array({normal_absolute(tileset).string()});
    for (const std::string& f : m.files) files.push_back(f);
    const std::string dir = first.parent_path().generic_string();
    out["tasks"].push_back({{"id", id},
                            {"input", normal_absolute(tileset).string()},
                            {"output_dir", "."},
                            {"stem", (first.parent_path() / first.stem()).generic_string()},
                            {"tile", dir.empty() ? id : dir},
                            {"level", level_of(first.stem().string())},
                            {"contents", m.contents},
                            {"args", args},
                            {"files", files}});
  }
  // A missing content or an unreadable external tileset is a task of its own that fails with the
  // reader's error (naming the file and the tileset naming it); the other tasks run.
  for (const TilesetBroken& b : plan.tileset.broken) {
    const fs::path rel = normal_absolute(b.path).lexically_relative(root);
    std::string id = (rel.parent_path() / rel.stem()).generic_string();
    if (!ids.insert(id).second) id = rel.generic_string();
    ids.insert(id);
    const std::string dir = rel.parent_path().generic_string();
    out["tasks"].push_back({{"id", id},
                            {"input", normal_absolute(tileset).string()},
                            {"output_dir", "."},
                            {"stem", id},
                            {"tile", dir.empty() ? id : dir},
                            {"level", level_of(rel.stem().string())},
                            {"contents", {rel.generic_string()}},
                            {"args", {"--contents", rel.generic_string()}},
                            {"files", {normal_absolute(tileset).string(), normal_absolute(b.tileset).string()}},
                            {"error", b.error}});
  }
  if (out["tasks"].empty()) throw std::runtime_error(tileset.string() + ": the tileset has no glTF or b3dm content");
  return out;
}

}  // namespace

/// The task list of a production (docs/batch.md, "Tasks"): {"input", "root", "kind", "tasks",
/// "copies"} (copies: files that pass through unchanged, {"input": absolute, "output": relative}). input: a folder (kind "folder": every model file under it, see folder_tasks) or one
/// model file (kind "file"); exclude: a folder never searched (the batch output), may be "".
/// Throws std::runtime_error naming the input when it is missing, unreadable or holds no model.
/// Production formats (OSGB metadata.xml pyramids, 3D Tiles tilesets) add their branch here.
json production_tasks(const std::string& input, const std::string& exclude) {
  const fs::path in(input);
  std::error_code ec;
  const auto st = fs::status(in, ec);
  if (ec || !fs::exists(st)) throw std::runtime_error(input + ": no such file or folder");
  json out = {{"input", normal_absolute(in).string()}, {"copies", json::array()}};
  if (fs::is_regular_file(st) && is_tileset(input)) return tileset_tasks(in);
  if (fs::is_directory(st) && !fs::exists(in / "metadata.xml", ec) && is_tileset((in / "tileset.json").string()))
    return tileset_tasks(in / "tileset.json");
  if (fs::is_regular_file(st)) {
    if (!is_model(in))
      throw std::runtime_error(input + ": not a production nor a model file (formats: " + format_names() + ")");
    out["kind"] = "file";
    out["root"] = normal_absolute(in.parent_path().empty() ? fs::path(".") : in.parent_path()).string();
    out["tasks"] = json::array({make_task(out["root"].get<std::string>(), in)});
    return out;
  }
  if (!fs::is_directory(st)) throw std::runtime_error(input + ": not a regular file or a folder");
  out["kind"] = "folder";
  out["root"] = out["input"];
  out["tasks"] = folder_tasks(in, exclude.empty() ? fs::path() : fs::path(exclude));
  // A ContextCapture production's metadata.xml (SRS, origin) passes through unchanged.
  if (fs::is_regular_file(in / "metadata.xml"))
    out["copies"].push_back({{"input", normal_absolute(in / "metadata.xml").string()}, {"output", "metadata.xml"}});
  if (fs::is_regular_file(in / "metadata.xml", ec)) {
    // A ContextCapture production (production/production.h): the level is the number in the name
    // (level_of above); a tile without one (the root .osgb of a Tile_* folder) takes the
    // production's name for it ("root").
    const Production p = list_production(input, "");
    for (json& t : out["tasks"])
      for (const ProductionTask& pt : p.tasks)
        if (t["level"].is_null() && normal_absolute(pt.input).string() == t["input"].get<std::string>() &&
            !pt.level.empty())
          t["level"] = pt.level;
  }
  if (out["tasks"].empty())
    throw std::runtime_error(input + ": no model file found (formats: " + format_names() +
                             "; searched recursively, hidden folders and texdefrag outputs skipped)");
  return out;
}

CLI::App* add_tasks_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string input, exclude, finish;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand("tasks", "List the tasks of a production (one per tile file and level)");
  sub->add_option("input", args->input, "Production: a folder of model files (OBJ tiles...) or one model file")->required();
  sub->add_option("--exclude", args->exclude, "A folder whose files are never tasks (the batch output)");
  sub->add_flag("--json", args->json, "JSON output (the batch driver's input; docs/batch.md)");
  sub->add_option("--finish", args->finish,
                  "Tileset input: write the tileset JSONs and pass-through contents into this output folder, "
                  "once every task's outputs are there (the batch's last step)");
  sub->callback([args, &exit_code] {
    try {
      if (!args->finish.empty()) {
        if (!is_tileset(args->input)) throw std::runtime_error(args->input + ": --finish applies to a tileset JSON");
        for (const std::string& f : finish_tileset(args->input, args->finish)) std::cout << f << "\n";
        exit_code = 0;
        return;
      }
      const json t = production_tasks(args->input, args->exclude);
      if (args->json) {
        std::cout << t.dump(1) << "\n";
      } else {
        for (const auto& task : t["tasks"])
          std::cout << task["id"].get<std::string>() << "\t" << task["input"].get<std::string>() << "\n";
        std::cerr << t["tasks"].size() << " task(s) in " << t["kind"].get<std::string>() << " " << t["input"].get<std::string>() << "\n";
      }
      exit_code = 0;
    } catch (const std::exception& e) {
      std::cerr << "texdefrag tasks: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

namespace {

/// The folder holding the texdefrag_batch package: installed beside the executable
/// (<prefix>/share/texdefrag/python), else the source tree's tools/batch, else "".
std::string driver_dir(const fs::path& self) {
  const fs::path installed = self.parent_path().parent_path() / "share" / "texdefrag" / "python";
  if (fs::exists(installed / "texdefrag_batch" / "__main__.py")) return installed.string();
  const fs::path source = fs::path(source_dir()) / "tools" / "batch";
  if (fs::exists(source / "texdefrag_batch" / "__main__.py")) return source.string();
  return "";
}

}  // namespace

CLI::App* add_batch_command(CLI::App& app, int& exit_code) {
  auto* sub = app.add_subcommand("batch", "Defragment a whole production: parallel, resumable, on one machine or a Dask cluster "
                                           "(texdefrag batch --help; docs/batch.md)");
  // Every argument, --help included, goes to the driver, whose parser is the one reference.
  sub->prefix_command();
  sub->set_help_flag();
  sub->callback([sub, &exit_code] {
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (ec) {
      std::cerr << "texdefrag batch: cannot locate this executable (/proc/self/exe): " << ec.message() << "\n";
      exit_code = 2;
      return;
    }
    const std::string dir = driver_dir(self);
    if (dir.empty()) {
      std::cerr << "texdefrag batch: the batch driver (texdefrag_batch) is neither in "
                << (self.parent_path().parent_path() / "share/texdefrag/python").string() << " nor in "
                << (fs::path(source_dir()) / "tools/batch").string() << "\n";
      exit_code = 2;
      return;
    }
    const char* old = std::getenv("PYTHONPATH");
    const std::string pythonpath = dir + (old && *old ? ":" + std::string(old) : "");
    ::setenv("PYTHONPATH", pythonpath.c_str(), 1);
    const std::string python = python_executable();
    std::vector<std::string> argv_s = {python, "-m", "texdefrag_batch", "--texdefrag", self.string(),
                                       "--plots-dir", data_dir("plots")};
    for (const auto& a : sub->remaining()) argv_s.push_back(a);
    std::vector<char*> argv;
    for (auto& s : argv_s) argv.push_back(s.data());
    argv.push_back(nullptr);
    std::cout.flush();
    std::cerr.flush();
    ::execv(python.c_str(), argv.data());
    std::cerr << "texdefrag batch: cannot run " << python << ": " << std::strerror(errno) << "\n";
    exit_code = 2;
  });
  return sub;
}

}  // namespace texdefrag::cli
