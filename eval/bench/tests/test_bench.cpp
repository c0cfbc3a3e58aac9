// Tests of the batch harness (eval/bench, docs/bench.md): discovery, labels, external outputs,
// tool logs, tables on hand-built records, and whole batches through the texdefrag executable on
// tiny generated models (repack config): records, resume, failures, sweeps, external mode.
#include "texdefrag/eval/bench.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::bench;

namespace {

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

std::vector<std::string> read_lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  std::string l;
  while (std::getline(in, l))
    if (!l.empty()) lines.push_back(l);
  return lines;
}

/// A tiny fragmented model (every triangle its own chart): nx*ny*2 faces, one 64^2 page.
std::string write_model(const fs::path& dir, const std::string& stem, int nx, int ny) {
  fs::create_directories(dir);
  const std::string image = (dir / (stem + ".png")).string();
  texdefrag::testing::write_test_image(image, 64, 64);
  const TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(nx, ny, 64, image);
  const std::string obj = (dir / (stem + ".obj")).string();
  write_obj(m, obj);
  return obj;
}

std::string repack_config() { return (fs::path(source_dir()) / "configs" / "repack.json").string(); }

BenchOptions options(const std::string& data, const std::string& out) {
  BenchOptions o;
  o.data = data;
  o.out_dir = out;
  o.configs = {repack_config()};
  o.exe = TEXDEFRAG_EXE;
  o.samples = 2000;
  o.jobs = 2;
  return o;
}

/// The header and rows of a CSV (RFC 4180 quoting; no newlines inside cells).
std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  for (const std::string& line : read_lines(p)) {
    std::vector<std::string> cells;
    std::string cur;
    bool quoted = false;
    for (size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (c == '"' && quoted && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';  // "" inside quotes
        ++i;
      } else if (c == '"') {
        quoted = !quoted;
      } else if (c == ',' && !quoted) {
        cells.push_back(cur);
        cur.clear();
      } else {
        cur += c;
      }
    }
    cells.push_back(cur);
    rows.push_back(cells);
  }
  return rows;
}

size_t column(const std::vector<std::string>& header, const std::string& name) {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return i;
  ADD_FAILURE() << "no column " << name;
  return 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pieces

TEST(BenchModels, FolderIsRecursiveSortedAndSkipsOutputsAndResults) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "b" / "zeta.obj", "v 0 0 0\n");
  write_text(d / "a" / "alpha.OBJ", "v 0 0 0\n");
  write_text(d / "a" / "notes.txt", "x");
  write_text(d / "out" / "alpha.obj", "v 0 0 0\n");                      // texdefrag output:
  write_text(d / "out" / "alpha.report.json", "{}");                       // has a run report
  write_text(d / "results" / "runs" / "x" / "y" / "gamma.obj", "v 0 0 0\n");  // under --out
  const auto models = discover_models(d.string(), (d / "results").string());
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].id, "alpha");
  EXPECT_EQ(models[1].id, "zeta");
  EXPECT_TRUE(fs::path(models[0].path).is_absolute());
}

TEST(BenchModels, FolderTakesEveryModelFormatButNotTilesetsOrImages) {
  // A production's tiles compare one by one: glTF/GLB and OSGB files are models like OBJ; a
  // tileset JSON (a whole production, for a manifest) and page images are not.
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "a.glb", "glTF");
  write_text(d / "b.gltf", "{}");
  write_text(d / "Data" / "Tile_+000_+000" / "c.osgb", "x");
  write_text(d / "d.obj", "v 0 0 0\n");
  write_text(d / "tileset.json", "{}");
  write_text(d / "page.jpg", "x");
  write_text(d / "noext", "glTFxxxx");  // a GLB by its first bytes
  const auto models = discover_models(d.string());
  std::vector<std::string> ids;
  for (const auto& m : models) ids.push_back(m.id);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<std::string>{"a", "b", "c", "d", "noext"}));
}

TEST(BenchModels, CollidingStemsUseRelativePaths) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "x" / "tile.obj", "v 0 0 0\n");
  write_text(d / "y" / "tile.obj", "v 0 0 0\n");
  const auto models = discover_models(d.string());
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].id, "x_tile");
  EXPECT_EQ(models[1].id, "y_tile");
}

TEST(BenchModels, ManifestRelativePathsNamesAndMeta) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "b0001" / "b0001.obj", "v 0 0 0\n");
  write_text(d / "sub" / "m.obj", "v 0 0 0\n");
  write_text(d / "manifest.json",
             R"({"models":[{"name":"b0001","obj":"b0001/b0001.obj","archetype":"tower","faces":120,"list":[1]},
                           {"path":"sub/m.obj"}]})");
  const auto models = discover_models((d / "manifest.json").string());
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].id, "b0001");
  EXPECT_EQ(models[0].meta["archetype"], "tower");
  EXPECT_EQ(models[0].meta["faces"], 120);
  EXPECT_FALSE(models[0].meta.contains("list"));
  EXPECT_EQ(models[1].id, "m");
  EXPECT_EQ(fs::path(models[1].path), fs::weakly_canonical(d / "sub" / "m.obj"));
}

TEST(BenchModels, BadDataIsAClearError) {
  const fs::path d = texdefrag::testing::temp_dir();
  EXPECT_THROW(discover_models((d / "absent").string()), BenchError);
  EXPECT_THROW(discover_models(d.string()), BenchError);  // no model
  write_text(d / "manifest.json", R"({"models":[{"path":"missing.obj"}]})");
  try {
    discover_models((d / "manifest.json").string());
    FAIL() << "expected BenchError";
  } catch (const BenchError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.obj"), std::string::npos) << e.what();
  }
  write_text(d / "bad.json", "{\"models\": 3}");
  EXPECT_THROW(discover_models((d / "bad.json").string()), BenchError);
}

TEST(BenchConfigs, LabelsSetsSweepsAndExternals) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "ext" / "x.obj", "");
  const auto cs = expand_configs({repack_config()}, {"packer.max_page_size=4096"},
                                 {"packer.gutter=2,8", "texture.filter=nearest,bilinear"}, {"mm=" + (d / "ext").string()});
  ASSERT_EQ(cs.size(), 5u);
  EXPECT_EQ(cs[0].label, "repack[max_page_size=4096,gutter=2,filter=nearest]");
  EXPECT_EQ(cs[1].label, "repack[max_page_size=4096,gutter=2,filter=bilinear]");
  EXPECT_EQ(cs[3].label, "repack[max_page_size=4096,gutter=8,filter=bilinear]");
  EXPECT_EQ(cs[3].sweep_key, "packer.gutter,texture.filter");
  EXPECT_EQ(cs[3].sweep_value, "8,bilinear");
  EXPECT_EQ(cs[3].overrides,
            (std::vector<std::string>{"packer.max_page_size=4096", "packer.gutter=8", "texture.filter=bilinear"}));
  EXPECT_EQ(cs[4].label, "mm");
  EXPECT_TRUE(cs[4].external());
  const auto plain = expand_configs({repack_config()}, {}, {}, {});
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].label, "repack");
  EXPECT_TRUE(plain[0].overrides.empty());
}

TEST(BenchConfigs, MalformedArgumentsAreErrors) {
  EXPECT_THROW(expand_configs({repack_config()}, {"gutter"}, {}, {}), BenchError);
  EXPECT_THROW(expand_configs({repack_config()}, {}, {"packer.gutter"}, {}), BenchError);
  EXPECT_THROW(expand_configs({repack_config()}, {}, {"packer.gutter=2,,4"}, {}), BenchError);
  EXPECT_THROW(expand_configs({repack_config(), repack_config()}, {}, {}, {}), BenchError);  // same label
  EXPECT_THROW(expand_configs({"/nonexistent/x.json"}, {}, {}, {}), BenchError);
  EXPECT_THROW(expand_configs({}, {}, {}, {"mm=/nonexistent"}), BenchError);
  EXPECT_THROW(expand_configs({}, {}, {}, {}), BenchError);
}

TEST(BenchConfigs, ValidationNamesTheBadOption) {
  const auto cs = expand_configs({repack_config()}, {"packer.gutter=-5"}, {}, {});
  try {
    validate_configs(cs);
    FAIL() << "expected BenchError";
  } catch (const BenchError& e) {
    EXPECT_NE(std::string(e.what()).find("gutter"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(validate_configs(expand_configs({repack_config()}, {"packer.gutter=2"}, {}, {})));
}

TEST(BenchExternal, FindsOutputsByStem) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "t015_L18" / "t015_L18_defrag.obj", "");
  write_text(d / "t016_L18" / "t016_L18-out.obj", "");
  write_text(d / "t078_L15.obj", "");
  write_text(d / "misc" / "t099_defrag.obj", "");
  write_text(d / "solo" / "anything.obj", "");
  EXPECT_EQ(fs::path(find_external_output(d.string(), "t015_L18")).filename(), "t015_L18_defrag.obj");
  EXPECT_EQ(fs::path(find_external_output(d.string(), "t016_L18")).filename(), "t016_L18-out.obj");
  EXPECT_EQ(fs::path(find_external_output(d.string(), "t078_L15")).filename(), "t078_L15.obj");
  EXPECT_EQ(fs::path(find_external_output(d.string(), "t099")).filename(), "t099_defrag.obj");
  EXPECT_EQ(fs::path(find_external_output(d.string(), "solo")).filename(), "anything.obj");
  EXPECT_EQ(find_external_output(d.string(), "t016_L1"), "");  // never a prefix of another stem
  EXPECT_EQ(find_external_output(d.string(), "t017_L18"), "");
}

TEST(BenchExternal, ParsesTheToolLog) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_text(d / "log.txt",
             "Removed 20194 duplicate vertices\nRemoved 4 non-manifold faces\n"
             "Atlas energy before optimization is 6.9233e-32\n"
             "TOTAL      1.000 , 0.202287 secs\n  count:                    197\n"
             "TOTAL      1.000 , 3.49328 secs\nAtlas energy after optimization is 0.0249965\n"
             "Packed 652 charts in 3.88672 seconds\nInputCharts 5907\nOutputCharts 652\nInputMP 3.96493\n"
             "RelativeMPChange -0.769886\nProcessing took 8.16833 seconds\n");
  const json j = parse_tool_log((d / "log.txt").string());
  EXPECT_EQ(j["InputCharts"].get<double>(), 5907);
  EXPECT_EQ(j["OutputCharts"].get<double>(), 652);
  EXPECT_DOUBLE_EQ(j["RelativeMPChange"].get<double>(), -0.769886);
  EXPECT_DOUBLE_EQ(j["processing_time_s"].get<double>(), 8.16833);
  EXPECT_DOUBLE_EQ(j["packing_time_s"].get<double>(), 3.88672);
  EXPECT_EQ(j["packed_charts"].get<double>(), 652);
  EXPECT_DOUBLE_EQ(j["optimization_time_s"].get<double>(), 3.49328);
  EXPECT_DOUBLE_EQ(j["energy_after"].get<double>(), 0.0249965);
  EXPECT_EQ(j["removed_duplicate_vertices"].get<double>(), 20194);
  EXPECT_EQ(j["removed_non_manifold_faces"].get<double>(), 4);
  EXPECT_FALSE(j.contains("count"));
  EXPECT_TRUE(parse_tool_log((d / "absent.txt").string()).empty());
}

TEST(BenchTables, DerivedMetricsSummaryAndWinners) {
  auto rec = [](const std::string& cfg, const std::string& model, double charts_rel, double arap, double mse) {
    json r = {{"config", cfg}, {"model", model}, {"overrides", json::array()}, {"status", "ok"}};
    r["eval"]["relative_change"] = {{"charts", charts_rel}, {"megapixels", -0.5}};
    r["eval"]["distortion"] = {{"arap", arap}};
    r["eval"]["fidelity"] = {{"mse", mse}, {"samples", 10}, {"psnr_db", mse == 0 ? json(nullptr) : json(30.0)}};
    r["run"] = {{"stages", {{"read", {{"peak_rss_bytes", 1048576}}}, {"write", {{"peak_rss_bytes", 3145728}}}}}};
    return r;
  };
  std::vector<json> rs = {rec("a", "m1", -0.9, 0.01, 0), rec("a", "m2", -0.8, 0.03, 0), rec("a", "m3", -0.7, 0.02, 0),
                          rec("b", "m1", -0.95, 0.05, 4), rec("b", "m2", -0.85, 0.04, 4)};
  json failed = {{"config", "b"}, {"model", "m3"}, {"overrides", json::array()}, {"status", "failed"}};
  rs.push_back(failed);
  const json d = derived_metrics(rs[0]);
  EXPECT_DOUBLE_EQ(d["chart_reduction"].get<double>(), 0.9);
  EXPECT_TRUE(std::isinf(d["psnr_db"].get<double>()));
  EXPECT_DOUBLE_EQ(d["peak_rss_mb"].get<double>(), 3.0);  // the largest stage peak
  EXPECT_TRUE(d["seam_3d_reduction"].is_null());
  const json s = summarize(rs);
  EXPECT_EQ(s["configs"]["a"]["ok"], 3);
  EXPECT_EQ(s["configs"]["b"]["failed"], 1);
  EXPECT_DOUBLE_EQ(s["configs"]["a"]["metrics"]["chart_reduction"]["median"].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(s["configs"]["b"]["metrics"]["chart_reduction"]["median"].get<double>(), 0.9);
  EXPECT_DOUBLE_EQ(s["configs"]["a"]["metrics"]["distortion_arap"]["mean"].get<double>(), 0.02);
  EXPECT_EQ(s["configs"]["a"]["metrics"]["psnr_db"]["median"], "inf");
  EXPECT_EQ(s["winners"]["chart_reduction"], json::array({"b"}));
  EXPECT_EQ(s["winners"]["distortion_arap"], json::array({"a"}));
  EXPECT_EQ(s["winners"]["texture_mp_change"], json::array({"a", "b"}));  // tie
  EXPECT_EQ(metric_direction("distortion_arap"), -1);
  EXPECT_EQ(metric_direction("chart_reduction"), +1);
  EXPECT_EQ(metric_direction("replication_in"), 0);
}

TEST(BenchTables, CsvQuotingAndRecordsLastWins) {
  const fs::path d = texdefrag::testing::temp_dir();
  json a = {{"config", "c"}, {"model", "m"}, {"overrides", json::array()}, {"status", "failed"},
            {"error", "exit code 1: bad, \"quoted\""}};
  json b = a;
  b["status"] = "ok";
  b["error"] = "";
  b["eval"]["relative_change"]["charts"] = -0.5;
  write_text(d / "r.jsonl", a.dump() + "\n" + "{truncated\n" + b.dump() + "\n");
  size_t bad = 0;
  const auto rs = read_records((d / "r.jsonl").string(), &bad);
  EXPECT_EQ(bad, 1u);
  ASSERT_EQ(rs.size(), 1u);
  EXPECT_EQ(rs[0]["status"], "ok");
  write_csv({a, b}, (d / "r.csv").string());
  const auto rows = read_csv(d / "r.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1][column(rows[0], "error")], "exit code 1: bad, \"quoted\"");
  EXPECT_EQ(rows[2][column(rows[0], "chart_reduction")], "0.5");
  EXPECT_EQ(rows[1][column(rows[0], "chart_reduction")], "");
}

TEST(BenchProcess, CapturesOutputExitCodesSignalsAndTimeouts) {
  const fs::path d = texdefrag::testing::temp_dir();
  const ChildResult ok = run_child({"/bin/sh", "-c", "echo hello; echo oops >&2"}, (d / "a").string());
  EXPECT_TRUE(ok.ok());
  EXPECT_EQ(ok.out, "hello\n");
  EXPECT_EQ(ok.err, "oops\n");
  const ChildResult bad = run_child({"/bin/sh", "-c", "echo broken input >&2; exit 3"}, (d / "b").string());
  EXPECT_FALSE(bad.ok());
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.describe().find("broken input"), std::string::npos) << bad.describe();
  const ChildResult sig = run_child({"/bin/sh", "-c", "kill -SEGV $$"}, (d / "c").string());
  EXPECT_EQ(sig.signal, 11);
  EXPECT_NE(sig.describe().find("signal 11"), std::string::npos) << sig.describe();
  const ChildResult slow = run_child({"/bin/sleep", "5"}, (d / "d").string(), 0.2);
  EXPECT_TRUE(slow.timed_out);
  EXPECT_LT(slow.wall_s, 3.0);
  const ChildResult none = run_child({"/nonexistent/program"}, (d / "e").string());
  EXPECT_FALSE(none.ok());
}

TEST(BenchViews, OneColourPerChart) {
  const fs::path d = texdefrag::testing::temp_dir();
  const std::string obj = write_model(d / "m", "grid", 2, 1);  // 4 triangles, 4 charts
  const auto written = write_chart_views(obj, (d / "views" / "charts").string(), 32);
  ASSERT_EQ(written.size(), 1u);
  EXPECT_EQ(fs::path(written[0]).filename(), "charts_page0.png");
  const Image im = read_image(written[0]);
  EXPECT_EQ(im.width, 32);  // 64^2 page scaled to 32
  EXPECT_EQ(im.height, 32);
  std::set<std::array<uint8_t, 3>> colours;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const uint8_t* p = &im.pixels[(static_cast<size_t>(y) * 32 + static_cast<size_t>(x)) * static_cast<size_t>(im.channels)];
      colours.insert({p[0], p[1], p[2]});
    }
  EXPECT_EQ(colours.size(), 5u);  // four charts and the background
  EXPECT_TRUE(colours.count({40, 40, 40}));
  for (int c = 0; c < 4; ++c) EXPECT_TRUE(colours.count(chart_colour(c))) << c;
  EXPECT_NE(chart_colour(0), chart_colour(1));
  EXPECT_THROW(write_chart_views((d / "absent.obj").string(), (d / "x").string()), std::exception);
}

TEST(BenchViews, RenderShowsEveryChartOnce) {
  const fs::path d = texdefrag::testing::temp_dir();
  const TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(2, 1, 64, (d / "p.png").string());
  const Image im = render_3d(m, {0, 1, 2, 3}, 100);
  EXPECT_EQ(std::max(im.width, im.height), 100);
  std::map<std::array<uint8_t, 3>, int> colours;
  for (size_t i = 0; i + 2 < im.pixels.size(); i += 3) ++colours[{im.pixels[i], im.pixels[i + 1], im.pixels[i + 2]}];
  // A flat grid has one shade: four chart colours and the background, each chart clearly visible.
  EXPECT_EQ(colours.size(), 5u);
  EXPECT_GT((colours[{245, 245, 245}]), 0);
  for (const auto& [c, n] : colours) EXPECT_GT(n, 100) << int(c[0]) << "," << int(c[1]) << "," << int(c[2]);
  EXPECT_THROW(render_3d(m, {0, 1}, 100), BenchError);
  const std::string obj = write_model(d / "m", "grid", 2, 1);
  EXPECT_EQ(write_region_render(obj, repack_config(), {}, (d / "r.png").string()), "");  // one region
  EXPECT_FALSE(fs::exists(d / "r.png"));
  EXPECT_TRUE(fs::exists(write_chart_render(obj, (d / "v" / "c.png").string(), 64)));
}

// ---------------------------------------------------------------------------------------------
// Whole batches through the texdefrag executable

TEST(BenchBatch, RunsRecordsResumesAndSurvivesFailures) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_model(d / "data" / "one", "small", 2, 1);   // 4 faces, 4 charts
  write_model(d / "data" / "two", "larger", 3, 2);  // 12 faces, 12 charts
  const fs::path out = d / "results";
  BenchOptions o = options((d / "data").string(), out.string());
  const BenchSummary s = run_bench(o);
  EXPECT_EQ(s.pairs, 2u);
  EXPECT_EQ(s.ran, 2u);
  EXPECT_EQ(s.failed, 0u);
  const auto recs = read_records((out / "results.jsonl").string());
  ASSERT_EQ(recs.size(), 2u);
  for (const json& r : recs) {
    ASSERT_EQ(r["status"], "ok") << r.dump(2);
    EXPECT_EQ(r["config"], "repack");
    const double faces = r["model"] == "small" ? 4 : 12;
    EXPECT_EQ(r["eval"]["input"]["charts"].get<double>(), faces);
    EXPECT_EQ(r["eval"]["output"]["charts"].get<double>(), faces);  // repack keeps the charts
    EXPECT_EQ(r["eval"]["matching"]["lost"], 0);
    EXPECT_EQ(r["eval"]["output"]["uv_overlaps"], 0);
    EXPECT_TRUE(r["run"]["stages"].contains("packers.shelf"));
    EXPECT_GT(r["run"]["stages"]["read"]["peak_rss_bytes"].get<double>(), 0);
    EXPECT_GT(r["run"]["child_max_rss_bytes"].get<double>(), 0);
    EXPECT_TRUE(fs::exists(r["output"].get<std::string>()));
    EXPECT_EQ(fs::path(r["output"].get<std::string>()).parent_path(), out / "runs" / "repack" / r["model"].get<std::string>());
  }
  auto rows = read_csv(out / "results.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(std::stod(rows[1][column(rows[0], "chart_reduction")]), 0.0);
  EXPECT_EQ(rows[1][column(rows[0], "status")], "ok");
  const json summary = json::parse(std::ifstream(out / "summary.json"));
  EXPECT_EQ(summary["configs"]["repack"]["ok"], 2);

  // Resume: nothing runs again, nothing is appended.
  const BenchSummary again = run_bench(o);
  EXPECT_EQ(again.skipped, 2u);
  EXPECT_EQ(again.ran, 0u);
  EXPECT_EQ(read_lines(out / "results.jsonl").size(), 2u);

  // A malformed model fails alone; the others are skipped (done) and the batch completes.
  write_text(d / "data" / "bad" / "broken.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
  const BenchSummary third = run_bench(o);
  EXPECT_EQ(third.pairs, 3u);
  EXPECT_EQ(third.skipped, 2u);
  EXPECT_EQ(third.failed, 1u);
  const auto all = read_records((out / "results.jsonl").string());
  ASSERT_EQ(all.size(), 3u);
  const json& broken = all[2];
  EXPECT_EQ(broken["model"], "broken");
  EXPECT_EQ(broken["status"], "failed");
  EXPECT_EQ(broken["failed_step"], "run");
  EXPECT_NE(broken["error"].get<std::string>().find("broken.obj"), std::string::npos) << broken["error"];
  rows = read_csv(out / "results.csv");
  EXPECT_EQ(rows.size(), 4u);
  // Failed pairs are not retried unless asked.
  EXPECT_EQ(run_bench(o).skipped, 3u);
  o.retry_failed = true;
  EXPECT_EQ(run_bench(o).failed, 1u);
  EXPECT_EQ(read_records((out / "results.jsonl").string()).size(), 3u);
}

TEST(BenchBatch, SweepGivesOneRowPerValue) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_model(d / "data", "tiny", 2, 1);
  BenchOptions o = options((d / "data").string(), (d / "results").string());
  o.sweeps = {"packer.gutter=1,6"};
  o.views = true;
  const BenchSummary s = run_bench(o);
  EXPECT_EQ(s.ran, 2u);
  for (const char* v : {"input", "repack[gutter=1]", "repack[gutter=6]"}) {
    EXPECT_TRUE(fs::exists(d / "results" / "views" / v / "tiny" / "charts_page0.png")) << v;
    EXPECT_TRUE(fs::exists(d / "results" / "views" / v / "tiny" / "charts_3d.png")) << v;
  }
  const auto recs = read_records((d / "results" / "results.jsonl").string());
  ASSERT_EQ(recs.size(), 2u);
  std::set<std::string> labels, values;
  for (const json& r : recs) {
    EXPECT_EQ(r["status"], "ok") << r.dump(2);
    labels.insert(r["config"].get<std::string>());
    values.insert(r["sweep_value"].get<std::string>());
    EXPECT_EQ(r["sweep_key"], "packer.gutter");
  }
  EXPECT_EQ(labels, (std::set<std::string>{"repack[gutter=1]", "repack[gutter=6]"}));
  EXPECT_EQ(values, (std::set<std::string>{"1", "6"}));
  // A wider gutter cannot give a better packing efficiency on the same charts.
  double eff1 = 0, eff6 = 0;
  for (const json& r : recs)
    (r["sweep_value"] == "1" ? eff1 : eff6) = r["eval"]["output"]["packing_efficiency"].get<double>();
  EXPECT_GE(eff1, eff6);
}

TEST(BenchBatch, ExternalOutputsAreEvaluatedLikeOurs) {
  const fs::path d = texdefrag::testing::temp_dir();
  write_model(d / "data" / "p", "alpha", 2, 1);
  write_model(d / "data" / "q", "beta", 2, 2);
  // First our own outputs, then a copy of alpha's output posing as another tool's.
  BenchOptions o = options((d / "data").string(), (d / "ours").string());
  ASSERT_EQ(run_bench(o).ran, 2u);
  const fs::path ext = d / "tool";
  fs::create_directories(ext / "alpha");
  for (const auto& e : fs::directory_iterator(d / "ours" / "runs" / "repack" / "alpha")) {
    const std::string name = e.path().filename().string();
    if (name.rfind("bench_", 0) == 0 || name.find(".report.json") != std::string::npos) continue;
    const std::string target = name == "alpha.obj" ? "alpha_defrag.obj" : name;
    fs::copy_file(e.path(), ext / "alpha" / target);
  }
  write_text(ext / "alpha" / "log.txt", "InputCharts 4\nOutputCharts 4\nProcessing took 1.25 seconds\n");

  BenchOptions x = options((d / "data").string(), (d / "ours").string());
  x.configs.clear();
  x.externals = {"tool=" + ext.string()};
  const BenchSummary s = run_bench(x);
  EXPECT_EQ(s.ran, 1u);
  EXPECT_EQ(s.missing, 1u);
  const auto recs = read_records((d / "ours" / "results.jsonl").string());
  ASSERT_EQ(recs.size(), 4u);
  const json* ours = nullptr;
  const json* tool = nullptr;
  for (const json& r : recs) {
    if (r["model"] != "alpha") continue;
    (r["config"] == "tool" ? tool : ours) = &r;
  }
  ASSERT_TRUE(ours && tool);
  EXPECT_EQ((*tool)["status"], "ok") << tool->dump(2);
  EXPECT_EQ((*tool)["kind"], "external");
  EXPECT_EQ((*tool)["tool_log"]["InputCharts"].get<double>(), 4);
  EXPECT_DOUBLE_EQ((*tool)["run"]["total_time_s"].get<double>(), 1.25);
  // The same files give the same metrics, whoever wrote them.
  for (const char* k : {"charts", "v2", "uv_border_length_texels", "megapixels", "packing_efficiency"})
    EXPECT_EQ((*tool)["eval"]["output"][k], (*ours)["eval"]["output"][k]) << k;
  EXPECT_EQ((*tool)["eval"]["distortion"]["arap"], (*ours)["eval"]["distortion"]["arap"]);
  for (const json& r : recs) {
    if (r["config"] == "tool" && r["model"] == "beta") {
      EXPECT_EQ(r["status"], "missing");
    }
  }
  const json summary = json::parse(std::ifstream(d / "ours" / "summary.json"));
  EXPECT_EQ(summary["configs"]["tool"]["missing"], 1);
  EXPECT_EQ(summary["configs"]["repack"]["ok"], 2);
}
