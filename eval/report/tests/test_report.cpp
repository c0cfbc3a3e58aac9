// The HTML report folder written for hand-built models: files, manifest, data chunks that decode
// back to the mesh, metrics table with the best value marked, the too-large message, and errors.
// (The report in a real browser: test_report_browser.)
#include "../src/export.h"
#include "texdefrag/eval/report.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace texdefrag;
namespace fx = texdefrag::testing;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// A dummy three.js: the HTML tests need a file to copy, not a working library.
std::string fake_three(const std::string& dir) {
  const std::string p = dir + "/three.js";
  std::ofstream(p) << "window.THREE = {};\n";
  return p;
}

/// An input (grid, 12 triangle charts) and an output (one chart) of the same 12 faces, as OBJ files.
report::ReportModel two_views(const std::string& dir) {
  fs::create_directories(dir + "/in");
  fs::create_directories(dir + "/out");
  TexturedMesh in = fx::fragmented_grid_mesh(3, 2, 64, dir + "/in/page.png");
  fx::write_surface_texture(in, 0, dir + "/in/page.png");
  write_obj(in, dir + "/in/model.obj");
  TexturedMesh out = fx::grid_mesh(3, 2, 64, dir + "/out/page.png");
  fx::write_test_image(dir + "/out/page.png", 64, 64);
  write_obj(out, dir + "/out/model.obj");
  report::ReportModel m;
  m.id = "model";
  m.input_obj = dir + "/in/model.obj";
  m.outputs.push_back({"one", dir + "/out/model.obj", {{"chart_reduction", 0.5}, {"distortion_arap", 0.01}, {"charts_in", 12}, {"charts_out", 6}}, "", {}, nullptr});
  m.outputs.push_back({"two", dir + "/out/model.obj", {{"chart_reduction", 0.9}, {"distortion_arap", 0.02}, {"charts_out", 1}}, "", {}, nullptr});
  return m;
}

}  // namespace

TEST(Report, Base64) {
  EXPECT_EQ(report::base64("", 0), "");
  EXPECT_EQ(report::base64("f", 1), "Zg==");
  EXPECT_EQ(report::base64("fo", 2), "Zm8=");
  EXPECT_EQ(report::base64("foobar", 6), "Zm9vYmFy");
}

TEST(Report, FolderManifestTablesAndData) {
  const std::string dir = fx::temp_dir();
  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = fake_three(dir);
  o.chunk_faces = 5;  // 12 faces: 3 chunks
  const report::ReportSummary s = report::write_report({two_views(dir)}, o);
  EXPECT_EQ(s.models, 1u);
  EXPECT_EQ(s.views, 3u);
  EXPECT_EQ(s.too_large, 0u);
  const fs::path r = o.out_dir;
  for (const char* f : {"index.html", "lib/three.js", "lib/viewer.js", "lib/report.css", "data/m0v0_g0.js", "data/m0v0_g2.js",
                        "data/m0v0_t0.js", "data/m0v2_g2.js", "atlas/m0v0_page0.png", "atlas/m0v1_page0.png"})
    EXPECT_TRUE(fs::exists(r / f)) << f;
  EXPECT_FALSE(fs::exists(r / "data/m0v0_g3.js"));
  const std::string page = slurp(r / "index.html");
  EXPECT_NE(page.find("\"views\":[{\"charts\":12"), std::string::npos);  // input: 12 charts
  EXPECT_NE(page.find("<script src=\"lib/three.js\"></script>"), std::string::npos);
  // Best values marked: larger chart reduction (two), smaller distortion (one).
  EXPECT_NE(page.find("<td>50.0%</td><td class=\"best\">90.0%</td>"), std::string::npos);
  EXPECT_NE(page.find("<td class=\"best\">0.01</td><td>0.02</td>"), std::string::npos);
  EXPECT_EQ(page.find("http://"), std::string::npos);  // nothing fetched from the network
  EXPECT_EQ(page.find("https://"), std::string::npos);
  // A chunk holds the faces' positions: 5 faces x 9 floats, base64.
  const std::string g0 = slurp(r / "data/m0v0_g0.js");
  EXPECT_EQ(g0.rfind("TD.chunk(\"m0v0\",0,", 0), 0u);
  const size_t at = g0.find('{');
  const nlohmann::json d = nlohmann::json::parse(g0.substr(at, g0.rfind(')') - at));
  EXPECT_EQ(d["faces"], 5);
  EXPECT_EQ(d["p"].get<std::string>().size(), (5 * 9 * 4 + 2) / 3 * 4);
  EXPECT_EQ(d["groups"], nlohmann::json::parse("[[0,0,5]]"));
  EXPECT_EQ(slurp(r / "data/m0v0_t0.js").rfind("TD.texture(\"m0v0\",0,\"data:image/jpeg;base64,", 0), 0u);
}

TEST(Report, TooLargeModelsGetNoViewerData) {
  const std::string dir = fx::temp_dir();
  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = fake_three(dir);
  o.max_faces = 11;
  const report::ReportSummary s = report::write_report({two_views(dir)}, o);
  EXPECT_EQ(s.too_large, 3u);
  EXPECT_FALSE(fs::exists(fs::path(o.out_dir) / "data/m0v0_g0.js"));
  EXPECT_NE(slurp(fs::path(o.out_dir) / "index.html").find("\"too_large\":true"), std::string::npos);
  EXPECT_NE(slurp(fs::path(o.out_dir) / "lib/viewer.js").find("too large to view here"), std::string::npos);
}

TEST(Report, ErrorsNameTheProblem) {
  const std::string dir = fx::temp_dir();
  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = dir + "/absent.js";
  try {
    report::write_report({two_views(dir)}, o);
    FAIL() << "no error";
  } catch (const report::ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("install-npm.sh"), std::string::npos);
  }
  EXPECT_THROW(report::models_from_bench(dir), report::ReportError);
  EXPECT_THROW(report::model_from_files(dir + "/absent.obj", {"x.obj"}, 100), report::ReportError);
  EXPECT_THROW(report::model_from_files(dir + "/in/model.obj", {"=" + dir + "/out/model.obj"}, 100), report::ReportError);
}

// A single run (texdefrag report --input): each output evaluated, and the report embeds the
// figures that make sense for one model: 16-18 as one bar per output, 19-20 per model, 21 the
// rendered fidelity against distance. (Small renders keep the evaluation quick.)
TEST(Report, SingleRunEvaluatesOutputsAndEmbedsFigures) {
  const std::string dir = fx::temp_dir();
  two_views(dir);
  eval::RenderFidelityOptions render;
  render.views = 2, render.size = 64, render.max_level = 2, render.supersample = 2;
  report::ReportModel m = report::model_from_files(dir + "/in/model.obj", {"merged=" + dir + "/out/model.obj"}, 500, render);
  ASSERT_EQ(m.outputs.size(), 1u);
  EXPECT_EQ(m.outputs[0].label, "merged");
  EXPECT_EQ(m.outputs[0].metrics["charts_in"], 12);
  EXPECT_EQ(m.outputs[0].metrics["charts_out"], 1);
  EXPECT_TRUE(m.outputs[0].metrics["rendered_psnr_l0"].is_number());
  EXPECT_TRUE(m.outputs[0].metrics["clash_fraction_l2_out"].is_number());
  EXPECT_TRUE(m.outputs[0].metrics["seam_colour_l2_in"].is_number());
  const nlohmann::json& rec = m.outputs[0].record;
  ASSERT_TRUE(rec.is_object());
  EXPECT_EQ(rec["config"], "merged");
  EXPECT_EQ(rec["model"], "model");
  EXPECT_EQ(rec["eval"]["rendered"]["levels"].size(), 3u);
  // A second output (the same files under another label) for the per-output figures.
  report::ReportOutput again = m.outputs[0];
  again.label = "again";
  again.record["config"] = again.record["base_config"] = "again";
  m.outputs.push_back(again);

  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = fake_three(dir);
  o.figures_note = report::write_run_figures(m, o.out_dir);
  if (!o.figures_note.empty()) GTEST_SKIP() << o.figures_note;
  o.figures_dir = o.out_dir + "/figures";
  report::write_report({m}, o);
  const std::string page = slurp(fs::path(o.out_dir) / "index.html");
  for (const char* f : {"fig16_chart_reduction.png", "fig17_seam_reduction.png", "fig18_distortion.png", "fig19_texture_size.png",
                        "fig20_vertex_replication.png", "fig21_rendered_mip.png"}) {
    EXPECT_TRUE(fs::is_regular_file(fs::path(o.out_dir) / "figures" / f)) << f;
    EXPECT_NE(page.find(std::string("<img src=\"figures/") + f + "\""), std::string::npos) << f;
  }
  // The table behind them: one row per output.
  const std::string csv = slurp(fs::path(o.out_dir) / "results.csv");
  EXPECT_NE(csv.find("merged,merged,output,,,model,ok"), std::string::npos) << csv.substr(0, 300);
  EXPECT_NE(csv.find("again,again,output,,,model,ok"), std::string::npos);
  // An output without an evaluation record cannot be plotted.
  report::ReportModel bare = m;
  bare.outputs[0].record = nullptr;
  EXPECT_THROW(report::write_run_figures(bare, dir + "/bare"), report::ReportError);
}

// Without figures, the reason is on the page.
TEST(Report, FiguresNoteWhenNoFigures) {
  const std::string dir = fx::temp_dir();
  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = fake_three(dir);
  o.figures_note = "plots: matplotlib is not available";
  report::write_report({two_views(dir)}, o);
  EXPECT_NE(slurp(fs::path(o.out_dir) / "index.html").find("plots: matplotlib is not available"), std::string::npos);
}

// A bench report embeds every figure of the results folder (Figures 16-21 and sweep plots),
// copied into the report folder.
TEST(Report, BenchFiguresAndSweepPlotsCopiedAndEmbedded) {
  const std::string dir = fx::temp_dir();
  fs::create_directories(dir + "/bench/figures");
  for (const char* f : {"fig16_chart_reduction.png", "fig21_rendered_mip.png", "sweep_packer.gutter.png"})
    fx::write_test_image(dir + "/bench/figures/" + f, 8, 8);
  std::ofstream(dir + "/bench/figures/notes.txt") << "not a figure\n";
  report::ReportOptions o;
  o.out_dir = dir + "/report";
  o.three_js = fake_three(dir);
  o.bench_dir = dir + "/bench";
  report::write_report({two_views(dir)}, o);
  const std::string page = slurp(fs::path(o.out_dir) / "index.html");
  for (const char* f : {"fig16_chart_reduction.png", "fig21_rendered_mip.png", "sweep_packer.gutter.png"}) {
    EXPECT_TRUE(fs::is_regular_file(fs::path(o.out_dir) / "figures" / f)) << f;
    EXPECT_NE(page.find(std::string("<img src=\"figures/") + f + "\""), std::string::npos) << f;
  }
  EXPECT_EQ(page.find("notes.txt"), std::string::npos);
}
