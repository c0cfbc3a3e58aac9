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
  m.outputs.push_back({"one", dir + "/out/model.obj", {{"chart_reduction", 0.5}, {"distortion_arap", 0.01}, {"charts_in", 12}, {"charts_out", 6}}, "", {}});
  m.outputs.push_back({"two", dir + "/out/model.obj", {{"chart_reduction", 0.9}, {"distortion_arap", 0.02}, {"charts_out", 1}}, "", {}});
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

TEST(Report, ModelFromFilesEvaluatesEachOutput) {
  const std::string dir = fx::temp_dir();
  two_views(dir);
  const report::ReportModel m = report::model_from_files(dir + "/in/model.obj", {"merged=" + dir + "/out/model.obj"}, 500);
  ASSERT_EQ(m.outputs.size(), 1u);
  EXPECT_EQ(m.outputs[0].label, "merged");
  EXPECT_EQ(m.outputs[0].metrics["charts_in"], 12);
  EXPECT_EQ(m.outputs[0].metrics["charts_out"], 1);
  EXPECT_TRUE(m.outputs[0].metrics["rendered_psnr_l0"].is_number());
  EXPECT_TRUE(m.outputs[0].metrics["clash_fraction_l2_out"].is_number());
}
