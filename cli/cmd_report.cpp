// `texdefrag report`: the HTML report of a bench result or of one input with its outputs
// (docs/report.md), optionally checked in headless Chromium (--check).
#include "commands.h"

#include "texdefrag/eval/bench.h"
#include "texdefrag/eval/report.h"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

namespace fs = std::filesystem;

namespace texdefrag::cli {
namespace {

/// Runs the browser check (Node.js + playwright-core driving Debian's Chromium) on a report
/// folder: 0 passed, 77 could not start (message printed), anything else failed.
int run_browser_check(const std::string& report_dir) {
  const std::string script = TEXDEFRAG_REPORT_CHECK_SCRIPT;
  const std::string modules = TEXDEFRAG_NODE_MODULES;
  if (!fs::exists(script) || !fs::exists(fs::path(modules) / "playwright-core")) {
    std::cerr << "texdefrag report --check: skipped: " << (fs::exists(script) ? modules + "/playwright-core" : script)
              << " not found (run scripts/install-npm.sh in the source tree)\n";
    return 77;
  }
  const std::string cmd = "NODE_PATH='" + modules + "' node '" + script + "' '" + report_dir + "'";
  const int st = std::system(cmd.c_str());
  return st == -1 ? 77 : (WIFEXITED(st) ? WEXITSTATUS(st) : 1);
}

}  // namespace

CLI::App* add_report_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string bench, input, out;
    std::vector<std::string> outputs;
    report::ReportOptions opt;
    size_t samples = 200000;
    bool check = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("report", "Write an HTML report (3D viewer, atlas pages, metrics, figures) of a "
                                               "bench result or of one input and its outputs (docs/report.md)");
  sub->add_option("--bench", a->bench, "bench results folder (results.jsonl, figures/)");
  sub->add_option("--input", a->input, "input OBJ (instead of --bench)");
  sub->add_option("--output", a->outputs, "an output of --input: [LABEL=]OBJ (repeatable; label = its folder name)");
  sub->add_option("-o,--out", a->out, "report folder (created)")->required();
  sub->add_option("--title", a->opt.title, "page title");
  sub->add_option("--max-faces", a->opt.max_faces, "views with more faces get no 3D viewer (the page says so)")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1) << 40));
  sub->add_option("--chunk-faces", a->opt.chunk_faces, "faces per geometry file (progressive loading)")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1) << 40));
  sub->add_option("--texture-max", a->opt.texture_max, "pixels: longer side of the viewer's textures")->check(CLI::Range(16, 16384));
  sub->add_option("--samples", a->samples, "with --input: texture fidelity samples per output")
      ->check(CLI::Range(static_cast<size_t>(1), static_cast<size_t>(1000000000)));
  sub->add_flag("--check", a->check, "open the report in headless Chromium, check the viewers and save thumbnails");
  sub->callback([a, &exit_code]() {
    if (a->bench.empty() == a->input.empty()) {
      std::cerr << "texdefrag report: give either --bench RESULTS or --input IN.obj --output OUT.obj ...\n";
      exit_code = 2;
      return;
    }
    if (!a->input.empty() && a->outputs.empty()) {
      std::cerr << "texdefrag report: --input needs at least one --output\n";
      exit_code = 2;
      return;
    }
    try {
      std::vector<report::ReportModel> models;
      if (!a->bench.empty()) {
        models = report::models_from_bench(a->bench);
        a->opt.bench_dir = a->bench;
      } else {
        models.push_back(report::model_from_files(a->input, a->outputs, a->samples));
        // The single run's figures (plots.py on its records): written into the report folder.
        a->opt.figures_note = report::write_run_figures(models.front(), a->out);
        a->opt.figures_dir = (fs::path(a->out) / "figures").string();
        if (!a->opt.figures_note.empty()) std::cerr << "texdefrag report: " << a->opt.figures_note << "\n";
      }
      a->opt.out_dir = a->out;
      const report::ReportSummary s = report::write_report(models, a->opt);
      std::fprintf(stderr, "%s: %zu models, %zu views (%zu too large for the viewer), %.1f MB of data\n",
                   s.index_html.c_str(), s.models, s.views, s.too_large, s.data_bytes / 1e6);
      exit_code = 0;
      if (a->check) {
        const int rc = run_browser_check(a->out);
        exit_code = rc == 77 ? 0 : (rc == 0 ? 0 : 1);
      }
    } catch (const std::exception& e) {
      std::cerr << "texdefrag report: " << e.what() << "\n";
      exit_code = 1;
    }
  });
  return sub;
}

}  // namespace texdefrag::cli
