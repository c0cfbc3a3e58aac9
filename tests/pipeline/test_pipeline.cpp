// The pipeline end to end: every configs/*.json runs, every configs/bad/*.json fails with its
// expected message, overrides, refusals, and the repack invariants on every real model.
#include "texdefrag/core/charts.h"
#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/parallel.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

std::string config_path(const std::string& name) { return (fs::path(source_dir()) / "configs" / name).string(); }

/// A small fragmented model on disk: a 4x3 grid, every triangle its own chart, one 64^2 page.
std::string small_model(const std::string& dir) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(4, 3, 128, dir + "/page.png");
  texdefrag::testing::write_surface_texture(m, 0, dir + "/page.png");
  write_obj(m, dir + "/small.obj");
  return dir + "/small.obj";
}

std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".json") out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

void expect_same_geometry(const std::string& in_obj, const std::string& out_obj) {
  const TexturedMesh in = read_obj(in_obj), out = read_obj(out_obj);
  ASSERT_EQ(in.faces.size(), out.faces.size());
  for (size_t f = 0; f < in.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(in.corner_position(f, k), out.corner_position(f, k)) << "face " << f;  // bit for bit
}

/// UV overlaps between triangles of the same chart (the rest are overlaps between charts).
size_t within_chart_overlaps(const std::string& obj) {
  const TexturedMesh m = eval::canonical_pages(read_obj(obj));
  const Topology t = build_topology(m);
  const ChartSet cs = build_charts(m, t);
  std::vector<std::vector<std::array<Vec2, 3>>> tris(static_cast<size_t>(cs.atlas.num_charts));
  for (size_t f = 0; f < m.faces.size(); ++f)
    if (cs.atlas.face_chart[f] >= 0)
      tris[static_cast<size_t>(cs.atlas.face_chart[f])].push_back({m.corner_texel(f, 0), m.corner_texel(f, 1), m.corner_texel(f, 2)});
  size_t n = 0;
  for (const auto& c : tris) n += eval::count_overlapping_pairs(c);
  return n;
}

}  // namespace

TEST(Configs, EveryBadConfigFailsWithItsMessage) {
  // One expected fragment per file: adding a bad config without an expectation fails this test.
  const std::map<std::string, std::string> expected = {
      {"bad_enum.json", "texture: 'filter' = \"bilinar\" is not one of \"nearest\" \"bilinear\" \"bicubic\" (did you mean \"bilinear\"?)"},
      {"float_for_int.json", "packer (packers.shelf): 'max_page_size' must be an integer, got 1024.5"},
      {"not_object.json", "the configuration must be a JSON object"},
      {"out_of_range.json", "packer (packers.shelf): 'gutter' = -1 outside [0, 64]"},
      {"section_not_object.json", "'detector' must be an object"},
      {"syntax_error.json", "syntax_error.json:2:38: invalid JSON"},
      {"type_not_string.json", "detector.type: must be a string naming a stage"},
      {"unknown_option.json", "unknown option 'gutterr' for packers.shelf (did you mean 'gutter'?)"},
      {"unknown_section.json", "unknown key 'packers' (did you mean 'packer'?)"},
      {"unknown_stage.json", "detector.type: unknown stage 'detectors.nonee' (did you mean 'detectors.none'?)"},
      {"wrong_kind.json", "merger.type: 'packers.shelf' is a packers stage, not one of mergers"},
      {"wrong_type.json", "packer (packers.shelf): 'gutter' must be an integer, got string"},
  };
  const auto files = files_in(config_path("bad"));
  ASSERT_FALSE(files.empty());
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    auto it = expected.find(f);
    ASSERT_NE(it, expected.end()) << "configs/bad/" << f << " has no expected message in this test";
    try {
      load_config(config_path("bad/" + f));
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(it->second), std::string::npos) << e.what();
    }
  }
}

TEST(Configs, AllErrorsAreReportedTogether) {
  try {
    parse_config(json::parse(R"({"packer": {"type": "packers.shelf", "gutter": -1, "max_page_size": "x"}, "texture": {"fill": "no"}})"), "t");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.errors.size(), 3u) << e.what();
  }
}

TEST(Configs, OverridesBySectionAndByStageName) {
  const PipelineConfig a = load_config(config_path("repack.json"), {"packer.gutter=7", "texture.filter=bicubic"});
  EXPECT_EQ(a.packer.options.get_int("gutter"), 7);
  EXPECT_EQ(a.texture.get_string("filter"), "bicubic");
  const PipelineConfig b = load_config(config_path("repack.json"), {"packers.shelf.gutter=2"});
  EXPECT_EQ(b.packer.options.get_int("gutter"), 2);
  EXPECT_THROW(load_config(config_path("repack.json"), {"packer.gutter=-3"}), ConfigError);
  EXPECT_THROW(load_config(config_path("repack.json"), {"packers.tetrisx.gutter=2"}), ConfigError);
  EXPECT_THROW(load_config(config_path("repack.json"), {"gutter"}), ConfigError);
}

TEST(Pipeline, EveryConfigRunsEndToEnd) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  std::vector<std::string> files = files_in(config_path(""));
  for (const std::string& f : files_in(config_path("ablations"))) files.push_back("ablations/" + f);
  ASSERT_GE(files.size(), 3u);
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    const PipelineConfig cfg = load_config(config_path(f));
    RunOptions ro;
    ro.input = model;
    ro.output_dir = dir + "/out_" + fs::path(f).parent_path().string() + "_" + fs::path(f).stem().string();
    const json report = run_pipeline(cfg, ro);
    EXPECT_TRUE(fs::exists(report["output"].get<std::string>()));
    expect_same_geometry(model, report["output"].get<std::string>());
    const eval::Comparison c = eval::compare_files(model, report["output"].get<std::string>());
    EXPECT_EQ(c.match.lost, 0u);
    EXPECT_EQ(c.match.added, 0u);
    EXPECT_EQ(c.output.uv_overlaps, 0u);
    EXPECT_EQ(c.distortion.flipped, 0u);
    EXPECT_GE(c.fidelity.psnr_db, 40.0);
    EXPECT_LE(c.output.charts, c.input.charts);
    if (cfg.merger.type != "mergers.none") {
      EXPECT_LT(c.output.charts, c.input.charts / 4);
    }
    for (const char* stage : {"read", "charts", "texture.resample", "write"})
      EXPECT_TRUE(report["stages"].contains(stage)) << stage;
    EXPECT_TRUE(fs::exists(ro.output_dir + "/small.report.json"));
  }
}

// Issue 11 ("eval computes distortion with the core's code"): the run report's distortion_arap
// (the merger's node: core/distortion.h on the merged atlas, in texels) and eval's distortion of the
// written output against the input (core/distortion.h on the two files) are one figure. The
// example building gives a distortion far from 0, so a difference in the measure shows.
TEST(Pipeline, EvalDistortionEqualsTheRunReports) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = (fs::path(source_dir()) / "examples" / "building" / "building.obj").string();
  for (const char* f : {"best.json", "ablations/arap.json"}) {
    SCOPED_TRACE(f);
    RunOptions ro;
    ro.input = model;
    ro.output_dir = dir + "/out_" + fs::path(f).stem().string();
    const json report = run_pipeline(load_config(config_path(f)), ro);
    const json* merger = nullptr;
    for (auto it = report["stages"].begin(); it != report["stages"].end(); ++it)
      if (it->value("section", "") == "merger") merger = &*it;
    ASSERT_NE(merger, nullptr) << report["stages"].dump();
    const double in_report = (*merger)["distortion_arap"].get<double>();
    eval::EvalOptions eo;
    eo.texture = false;
    eo.appearance = false;
    const eval::Comparison c = eval::compare_files(model, report["output"].get<std::string>(), eo);
    std::printf("%s: distortion_arap %.9g in the run report, %.9g by eval; flipped %zu / %zu\n", f, in_report,
                c.distortion.arap, (*merger)["flipped_faces"].get<size_t>(), c.distortion.flipped);
    EXPECT_GT(in_report, 1e-4) << "too small to tell two measures apart";
    EXPECT_NEAR(c.distortion.arap, in_report, 1e-6 * in_report) << "eval " << c.distortion.arap << ", report " << in_report;
    EXPECT_EQ(c.distortion.flipped, (*merger)["flipped_faces"].get<size_t>());
    EXPECT_EQ(c.match.lost, 0u);
  }
}

TEST(Pipeline, RefusesToWriteIntoTheInputFolder) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  RunOptions ro;
  ro.input = model;
  ro.output_dir = dir;
  EXPECT_THROW(run_pipeline(load_config(config_path("repack.json")), ro), StageError);
}

TEST(Pipeline, BadInputNamesTheFile) {
  const std::string dir = texdefrag::testing::temp_dir();
  std::ofstream(dir + "/bad.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n";
  RunOptions ro;
  ro.input = dir + "/bad.obj";
  ro.output_dir = dir + "/out";
  try {
    run_pipeline(load_config(config_path("repack.json")), ro);
    FAIL();
  } catch (const ObjError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.obj:4"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/out/bad.obj"));
}

TEST(Pipeline, APageThatCannotBeDecodedFailsTheSameWithAnyThreadCount) {
  // The page's header reads (the reader takes its size from it) but its pixels do not. With two
  // threads the pages are decoded while the stages run (EarlyPages), with one at the resampling:
  // the same error either way, and nothing written.
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  const auto size = fs::file_size(dir + "/page.png");
  fs::resize_file(dir + "/page.png", size / 2);
  std::string messages[2];
  for (int threads = 1; threads <= 2; ++threads) {
    set_thread_count(threads);
    RunOptions ro;
    ro.input = model;
    ro.output_dir = dir + "/out" + std::to_string(threads);
    try {
      run_pipeline(load_config(config_path("repack.json")), ro);
      ADD_FAILURE() << threads << " threads: no error";
    } catch (const std::exception& e) {
      messages[threads - 1] = e.what();
    }
    EXPECT_FALSE(fs::exists(ro.output_dir + "/small.obj"));
  }
  set_thread_count(0);
  EXPECT_NE(messages[0].find("page.png"), std::string::npos) << messages[0];
  EXPECT_EQ(messages[0], messages[1]);
}

TEST(PipelineReal, RepackKeepsGeometryAndTexture) {
  const auto models = texdefrag::testing::real_models(25000);
  if (models.empty()) GTEST_SKIP() << "shared data absent: ../shared/data";
  const PipelineConfig cfg = load_config(config_path("repack.json"));
  for (const std::string& model : models) {
    SCOPED_TRACE(model);
    RunOptions ro;
    ro.input = model;
    ro.output_dir = texdefrag::testing::temp_dir("_" + fs::path(model).stem().string());
    const json report = run_pipeline(cfg, ro);
    const std::string out = report["output"].get<std::string>();
    expect_same_geometry(model, out);
    eval::EvalOptions eo;
    eo.fidelity.samples = 200000;
    const eval::Comparison c = eval::compare_files(model, out, eo);
    EXPECT_EQ(c.match.lost, 0u);
    EXPECT_EQ(c.match.moved_positions, 0u);
    // Charts only move: overlaps inside input charts (real tiles have some) stay; overlaps between
    // input charts (atlases that reuse texels) are separated; none are added.
    EXPECT_LE(c.output.uv_overlaps, c.input.uv_overlaps);
    EXPECT_EQ(c.output.uv_overlaps, within_chart_overlaps(out));
    EXPECT_EQ(c.output.charts, c.input.charts);
    EXPECT_LT(c.distortion.arap, 1e-20);
    EXPECT_GE(c.fidelity.psnr_db, 40.0);
    // Only translated: every face is a whole-texel move, so the texture is copied exactly.
    EXPECT_GT(c.fidelity.rigid_fraction, 0.999);
    EXPECT_GT(c.fidelity.copied_fraction, 0.999);
    std::printf("%s: %zu charts, %.2f MP -> %.2f MP, PSNR %.1f dB, copied %.4f, %.2f s\n", model.c_str(),
                c.input.charts, c.input.megapixels, c.output.megapixels, c.fidelity.psnr_db,
                c.fidelity.copied_fraction, report["total_time_s"].get<double>());
  }
}
