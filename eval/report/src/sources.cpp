// Where a report's models come from: a bench results folder, or an input and its outputs given on
// the command line (evaluated here for the table).
#include "texdefrag/eval/bench.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/eval/report.h"

#include <cstdlib>
#include <filesystem>
#include <map>

namespace fs = std::filesystem;

#ifndef TEXDEFRAG_THREE_BUNDLE
#define TEXDEFRAG_THREE_BUNDLE ""
#endif

namespace texdefrag::report {

std::string default_three_bundle() {
  if (const char* env = std::getenv("TEXDEFRAG_THREE_JS"); env && *env) return env;
  return TEXDEFRAG_THREE_BUNDLE;
}

std::vector<ReportModel> models_from_bench(const std::string& results_dir) {
  const fs::path jsonl = fs::path(results_dir) / "results.jsonl";
  if (!fs::exists(jsonl)) throw ReportError(jsonl.string() + ": no such file (not a bench results folder)");
  const std::vector<json> records = bench::read_records(jsonl.string());
  std::vector<ReportModel> models;
  std::map<std::string, size_t> index;
  // Column order: labels in first-seen order, the same for every model.
  std::vector<std::string> labels;
  for (const json& r : records) {
    if (r.value("status", "") != "ok" || !r.contains("output") || !r["output"].is_string()) continue;
    const std::string label = r.value("config", "");
    if (std::find(labels.begin(), labels.end(), label) == labels.end()) labels.push_back(label);
    const std::string id = r.value("model", "");
    auto it = index.find(id);
    if (it == index.end()) {
      it = index.emplace(id, models.size()).first;
      models.push_back({id, r.value("model_path", ""), {}});
    }
    ReportOutput o;
    o.label = label;
    o.obj = r["output"].get<std::string>();
    o.metrics = bench::derived_metrics(r);
    o.config_path = r.value("config_path", "");
    if (r.contains("overrides") && r["overrides"].is_array())
      for (const json& s : r["overrides"])
        if (s.is_string()) o.overrides.push_back(s.get<std::string>());
    models[it->second].outputs.push_back(std::move(o));
  }
  if (models.empty()) throw ReportError(jsonl.string() + ": no successful record");
  for (ReportModel& m : models)
    std::stable_sort(m.outputs.begin(), m.outputs.end(), [&](const ReportOutput& a, const ReportOutput& b) {
      return std::find(labels.begin(), labels.end(), a.label) < std::find(labels.begin(), labels.end(), b.label);
    });
  std::sort(models.begin(), models.end(), [](const ReportModel& a, const ReportModel& b) { return a.id < b.id; });
  return models;
}

ReportModel model_from_files(const std::string& input_obj, const std::vector<std::string>& outputs, size_t samples,
                             const eval::RenderFidelityOptions& render) {
  if (!fs::is_regular_file(input_obj)) throw ReportError(input_obj + ": no such file");
  ReportModel m;
  m.id = fs::path(input_obj).stem().string();
  m.input_obj = fs::absolute(input_obj).string();
  for (const std::string& arg : outputs) {
    ReportOutput o;
    const size_t eq = arg.find('=');
    o.obj = eq == std::string::npos ? arg : arg.substr(eq + 1);
    o.label = eq == std::string::npos ? fs::absolute(o.obj).parent_path().filename().string() : arg.substr(0, eq);
    if (o.label.empty() || o.obj.empty()) throw ReportError("--output '" + arg + "': expected LABEL=PATH or PATH");
    if (!fs::is_regular_file(o.obj)) throw ReportError(o.obj + ": no such file");
    for (const ReportOutput& p : m.outputs)
      if (p.label == o.label) throw ReportError("--output: label '" + o.label + "' given twice");
    o.obj = fs::absolute(o.obj).string();
    eval::EvalOptions opt;
    opt.fidelity.samples = samples;
    opt.render = render;
    o.record = {{"config", o.label}, {"base_config", o.label}, {"kind", "output"}, {"model", m.id},
                {"model_path", m.input_obj}, {"status", "ok"}, {"output", o.obj},
                {"eval", eval::to_json(eval::compare_files(m.input_obj, o.obj, opt))}};
    o.metrics = bench::derived_metrics(o.record);
    m.outputs.push_back(std::move(o));
  }
  return m;
}

std::string write_run_figures(const ReportModel& model, const std::string& out_dir) {
  std::vector<json> records;
  for (const ReportOutput& o : model.outputs) {
    if (!o.record.is_object()) throw ReportError("write_run_figures: output '" + o.label + "' has no evaluation record");
    records.push_back(o.record);
  }
  fs::create_directories(fs::path(out_dir) / "figures");
  const std::string csv = (fs::path(out_dir) / "results.csv").string();
  bench::write_csv(records, csv);
  const bench::PlotsResult p =
      bench::run_plots({"--results", out_dir, "--csv", csv, "--figures", (fs::path(out_dir) / "figures").string(), "--summary",
                        (fs::path(out_dir) / "summary.md").string()},
                       (fs::path(out_dir) / "figures" / "plots").string());  // plots.stdout, .stderr
  return p.figures ? "" : p.message;
}

}  // namespace texdefrag::report
