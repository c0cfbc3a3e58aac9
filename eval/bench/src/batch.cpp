// The batch driver of `texdefrag bench` (docs/bench.md): one child `texdefrag run` and one child
// evaluation per (configuration, model) pair, records appended to results.jsonl as they finish.
#include "texdefrag/eval/bench.h"

#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/util/memory.h"

#include <atomic>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <thread>

namespace fs = std::filesystem;

namespace texdefrag::bench {
namespace {

std::string now_iso() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string self_exe() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.string();
}

json base_record(const BenchConfig& c, const BenchModel& m) {
  json r;
  r["config"] = c.label;
  r["base_config"] = c.base;
  r["kind"] = c.external() ? "external" : "pipeline";
  r["config_path"] = c.external() ? c.external_dir : c.path;
  r["overrides"] = c.overrides;
  r["sweep_key"] = c.sweep_key;
  r["sweep_value"] = c.sweep_value;
  r["model"] = m.id;
  r["model_path"] = m.path;
  r["meta"] = m.meta;
  r["status"] = "ok";
  r["error"] = "";
  r["failed_step"] = "";
  return r;
}

void fail(json& r, const std::string& step, const std::string& error) {
  r["status"] = "failed";
  r["failed_step"] = step;
  r["error"] = error;
}

/// The run report's per-stage time and peak memory (and the stage's own scalar figures).
json run_figures(const json& report) {
  json run = json::object();
  for (const char* k : {"total_time_s", "total_cpu_s", "peak_rss_bytes", "threads"})
    if (report.contains(k)) run[k] = report[k];
  json stages = json::object();
  if (report.contains("stages") && report["stages"].is_object())
    for (const auto& [name, node] : report["stages"].items()) {
      json s = json::object();
      if (node.is_object())
        for (const auto& [k, v] : node.items())
          if (v.is_primitive()) s[k] = v;
      stages[name] = s;
    }
  run["stages"] = stages;
  return run;
}

/// Evaluates `output` against the model in a child process; fills the record's eval fields.
void evaluate_into(json& r, const BenchOptions& o, const std::string& exe, const BenchModel& m,
                   const std::string& output, const std::string& capture_prefix) {
  std::vector<std::string> argv = {exe, "bench", "--eval-pair", m.path, output, "--samples", std::to_string(o.samples)};
  if (!o.texture) argv.push_back("--no-texture");
  const ChildResult ev = run_child(argv, capture_prefix, o.timeout_s);
  r["eval_wall_s"] = ev.wall_s;
  r["eval_max_rss_bytes"] = ev.max_rss_bytes;
  if (!ev.ok()) {
    fail(r, "eval", ev.describe());
    return;
  }
  try {
    const json e = json::parse(ev.out);
    r["eval"] = e.at("comparison");
    r["eval_time_s"] = e.at("eval_time_s");
  } catch (const json::exception& ex) {
    fail(r, "eval", std::string("unreadable evaluation output: ") + ex.what());
  }
}

json run_pair(const BenchOptions& o, const std::string& exe, const BenchConfig& c, const BenchModel& m,
              const fs::path& runs_root) {
  json r = base_record(c, m);
  const fs::path dir = runs_root / c.label / m.id;
  std::error_code ec;
  fs::remove_all(dir, ec);  // stale outputs of an earlier, unfinished attempt
  fs::create_directories(dir, ec);
  if (ec) {
    fail(r, "setup", "cannot create " + dir.string() + ": " + ec.message());
    return r;
  }
  std::string output;
  if (c.external()) {
    output = find_external_output(c.external_dir, fs::path(m.path).stem().string());
    if (output.empty()) {
      r["status"] = "missing";
      r["error"] = "no output of " + c.label + " for " + fs::path(m.path).stem().string() + " in " + c.external_dir;
      return r;
    }
    const fs::path log = fs::path(output).parent_path() / "log.txt";
    json tool = parse_tool_log(log.string());
    r["tool_log"] = tool;
    json run = json::object();
    if (tool.contains("processing_time_s")) run["total_time_s"] = tool["processing_time_s"];
    run["source"] = tool.empty() ? "none" : "log.txt";
    r["run"] = run;
  } else {
    // The input comes first: CLI11's repeatable --set would swallow a positional after it.
    std::vector<std::string> argv = {exe, "run", m.path, "--config", c.path};
    for (const auto& s : c.overrides) argv.insert(argv.end(), {"--set", s});
    argv.insert(argv.end(), {"-o", dir.string(), "--quiet", "--report"});
    if (o.threads >= 0) argv.insert(argv.end(), {"--threads", std::to_string(o.threads)});
    const ChildResult run = run_child(argv, (dir / "bench_run").string(), o.timeout_s);
    json figures = json::object();
    r["run"] = {{"exit_code", run.exit_code}, {"wall_s", run.wall_s}, {"child_max_rss_bytes", run.max_rss_bytes}};
    if (!run.ok()) {
      fail(r, "run", run.describe());
      return r;
    }
    json report;
    try {
      report = json::parse(run.out);
    } catch (const json::exception&) {
      // The report is also written beside the output.
      const fs::path side = dir / (fs::path(m.path).stem().string() + ".report.json");
      std::ifstream in(side);
      try {
        if (in) in >> report;
      } catch (const json::exception&) {
        report = nullptr;
      }
    }
    if (!report.is_object()) {
      fail(r, "run", "the run printed no readable report");
      return r;
    }
    json rf = run_figures(report);
    rf.update(r["run"]);
    r["run"] = rf;
    output = report.value("output", (dir / (fs::path(m.path).stem().string() + ".obj")).string());
  }
  r["output"] = output;
  evaluate_into(r, o, exe, m, output, (dir / "bench_eval").string());
  return r;
}

std::string short_result(const json& r) {
  if (r["status"] != "ok") return r["status"].get<std::string>() + ": " + r["error"].get<std::string>();
  const json d = derived_metrics(r);
  char buf[200];
  auto pct = [&](const char* k) { return d[k].is_number() ? 100.0 * d[k].get<double>() : 0.0; };
  std::snprintf(buf, sizeof buf, "ok: charts -%.1f%%, seam 3D -%.1f%%, MP %+.1f%%, ARAP %.4f", pct("chart_reduction"),
                pct("seam_3d_reduction"), pct("texture_mp_change"),
                d["distortion_arap"].is_number() ? d["distortion_arap"].get<double>() : 0.0);
  return buf;
}

/// Chart-coloured views of every successful pair of this invocation that has none yet.
void write_views(const BenchOptions&, const std::vector<BenchConfig>& configs, const std::vector<BenchModel>& models,
                 const std::vector<json>& records, const fs::path& root,
                 const std::function<void(const std::string&)>& log) {
  std::map<std::string, const json*> by_key;
  for (const json& r : records) by_key[record_key(r)] = &r;
  for (const BenchConfig& c : configs)
    for (const BenchModel& m : models) {
      const auto it = by_key.find(record_key(base_record(c, m)));
      if (it == by_key.end() || (*it->second)["status"] != "ok") continue;
      const json& r = *it->second;
      const std::pair<fs::path, std::string> jobs[] = {{root / "input" / m.id, m.path},
                                                       {root / c.label / m.id, r.value("output", "")}};
      for (const auto& [dir, obj] : jobs) {
        if (fs::exists(dir) || obj.empty()) continue;
        try {
          fs::create_directories(dir);
          const auto written = write_chart_views(obj, (dir / "charts").string());
          write_chart_render(obj, (dir / "charts_3d.png").string());
          const bool regions = dir != root / "input" && !c.external() &&
                               !write_region_render(m.path, c.path, c.overrides, (dir / "regions_3d.png").string()).empty();
          log("views: " + std::to_string(written.size()) + " page(s), charts_3d" + (regions ? ", regions_3d" : "") +
              " in " + dir.string());
        } catch (const std::exception& e) {
          std::error_code ec;
          fs::remove_all(dir, ec);
          log("views: " + c.label + " " + m.id + ": " + e.what());
        }
      }
    }
}

}  // namespace

json evaluate_pair(const std::string& input_obj, const std::string& output_obj, size_t samples, bool texture) {
  eval::EvalOptions opt;
  opt.fidelity.samples = samples;
  opt.texture = texture;
  const auto t0 = std::chrono::steady_clock::now();
  const eval::Comparison c = eval::compare_files(input_obj, output_obj, opt);
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return {{"comparison", eval::to_json(c)}, {"eval_time_s", t}, {"peak_rss_bytes", peak_rss_bytes()}};
}

namespace {

/// One (configuration, model) pair of run_bench left to run.
struct BenchTask {
  const BenchConfig* config;
  const BenchModel* model;
};

using LogFn = std::function<void(const std::string&)>;

/// The pairs of configs x models (that order) to run: every pair but those `done` records (key ->
/// status), failed ones too when o.retry_failed. Counts pairs and skipped ones in `sum`.
std::vector<BenchTask> pending_tasks(const BenchOptions& o, const std::vector<BenchConfig>& configs,
                                     const std::vector<BenchModel>& models, const std::map<std::string, std::string>& done,
                                     BenchSummary& sum, const LogFn& log) {
  std::vector<BenchTask> tasks;
  for (const BenchConfig& c : configs)
    for (const BenchModel& m : models) {
      ++sum.pairs;
      json probe = base_record(c, m);
      const auto it = done.find(record_key(probe));
      if (it != done.end() && !(o.retry_failed && it->second == "failed")) {
        ++sum.skipped;
        log("skip " + c.label + " " + m.id + " (already recorded: " + it->second + ")");
        continue;
      }
      tasks.push_back({&c, &m});
    }
  return tasks;
}

/// Runs `tasks` on up to o.jobs threads (run_pair, runs under out/runs), appending each record to
/// `jsonl` as it finishes (a thrown error becomes a failed record) and counting it in `sum`.
/// Throws BenchError when jsonl cannot be written.
void run_tasks(const BenchOptions& o, const std::string& exe, const std::vector<BenchTask>& tasks, const fs::path& out,
               const fs::path& jsonl, BenchSummary& sum, const LogFn& log) {
  std::mutex mu;
  std::ofstream append(jsonl, std::ios::app);
  if (!append) throw BenchError("cannot write " + jsonl.string());
  std::atomic<size_t> next{0};
  size_t finished = 0;
  auto worker = [&] {
    for (;;) {
      const size_t i = next++;
      if (i >= tasks.size()) return;
      json r;
      try {
        r = run_pair(o, exe, *tasks[i].config, *tasks[i].model, out / "runs");
      } catch (const std::exception& e) {
        r = base_record(*tasks[i].config, *tasks[i].model);
        fail(r, "bench", e.what());
      }
      r["finished_at"] = now_iso();
      std::lock_guard<std::mutex> lock(mu);
      append << r.dump() << "\n";
      append.flush();
      const std::string status = r["status"];
      if (status == "ok") ++sum.ran;
      else if (status == "missing") ++sum.missing;
      else ++sum.failed;
      ++finished;
      log("[" + std::to_string(finished) + "/" + std::to_string(tasks.size()) + "] " + tasks[i].config->label + " " +
          tasks[i].model->id + ": " + short_result(r));
    }
  };
  std::vector<std::thread> threads;
  const int n = std::min<int>(o.jobs, static_cast<int>(std::max<size_t>(tasks.size(), 1)));
  for (int t = 0; t < n; ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  append.close();
  if (!append) throw BenchError("error writing " + jsonl.string());
}

}  // namespace

BenchSummary run_bench(const BenchOptions& o) {
  if (o.out_dir.empty()) throw BenchError("--out: no results folder given");
  if (o.jobs < 1) throw BenchError("-j must be at least 1");
  const std::vector<BenchConfig> configs = expand_configs(o.configs, o.sets, o.sweeps, o.externals);
  validate_configs(configs);
  const std::vector<BenchModel> models = discover_models(o.data, o.out_dir);
  const std::string exe = o.exe.empty() ? self_exe() : o.exe;
  if (exe.empty() || !fs::is_regular_file(exe)) throw BenchError("cannot find the texdefrag executable ('" + exe + "')");

  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) throw BenchError("cannot create " + o.out_dir + ": " + ec.message());
  const fs::path out = o.out_dir;
  const fs::path jsonl = out / "results.jsonl";

  std::map<std::string, std::string> done;  // key -> status
  for (const json& r : read_records(jsonl.string())) done[record_key(r)] = r.value("status", "");

  BenchSummary sum;
  const LogFn log = [&](const std::string& line) {
    if (o.log) o.log(line);
  };
  const std::vector<BenchTask> tasks = pending_tasks(o, configs, models, done, sum, log);
  run_tasks(o, exe, tasks, out, jsonl, sum, log);

  size_t bad = 0;
  const std::vector<json> all = read_records(jsonl.string(), &bad);
  if (o.views) write_views(o, configs, models, all, out / "views", log);
  if (bad) log("warning: " + std::to_string(bad) + " malformed line(s) in " + jsonl.string() + " ignored");
  write_csv(all, (out / "results.csv").string());
  const json summary = summarize(all);
  write_file_atomic((out / "summary.json").string(), summary.dump(2) + "\n");
  return sum;
}

}  // namespace texdefrag::bench
