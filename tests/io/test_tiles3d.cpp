// 3D Tiles: tilesets built here (b3dm with feature/batch tables, GLB, an external tileset), run
// through the pipeline as one production, checked structurally, compared tile by tile, and
// converted back with npm 3d-tiles-tools when it is installed.
#include "gltf_test_util.h"

#include "texdefrag/io/tiles3d.h"
#include "texdefrag/pipeline/pipeline.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <map>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::gltf_test;
using texdefrag::testing::temp_dir;
using ojson = nlohmann::ordered_json;

namespace {

/// GLB bytes of a fragmented textured grid at height z (embedded PNG page).
std::string grid_glb(const std::string& dir, int n, float z) {
  tinygltf::Model m = base_model();
  m.nodes[0].matrix.clear();  // identity: the tile box below is in glTF coordinates turned z-up
  m.meshes[0].primitives.push_back(add_primitive(m, grid(n, n, z), add_textured_material(m, png_bytes(dir, 32, 32))));
  save(m, dir + "/tmp.glb");
  const auto b = file_bytes(dir + "/tmp.glb");
  fs::remove(dir + "/tmp.glb");
  return std::string(b.begin(), b.end());
}

/// A box holding x in [0, n], glTF y in [0, n] (tile -z), glTF z = h (tile y = -h... ) after y-up to z-up.
ojson box_for(int n, float z) {
  // glTF (x, y, z) -> tile (x, -z, y)
  return {{"box", {n / 2.0, -z, n / 2.0, n / 2.0 + 0.01, 0, 0, 0, 0.01, 0, 0, 0, n / 2.0 + 0.01}}};
}

/// tileset.json (1.0) -> b3dm child, GLB child (3DTILES_content_gltf), external sub/ext.json -> GLB.
std::string build_tileset(const std::string& dir) {
  B3dm b;
  b.feature_table_json = R"({"BATCH_LENGTH":0,"RTC_CENTER":[0,0,0]})";
  while ((28 + b.feature_table_json.size()) % 8) b.feature_table_json += ' ';
  b.batch_table_json = R"({"name":[]}   )";
  const std::string g0 = grid_glb(dir, 2, 0.0f);
  b.glb.assign(g0.begin(), g0.end());
  put_file(dir + "/in/tiles/a.b3dm", write_b3dm(b));
  put_file(dir + "/in/tiles/b.glb", grid_glb(dir, 3, 1.0f));
  put_file(dir + "/in/sub/c.glb", grid_glb(dir, 2, 2.0f));
  ojson ext = {{"asset", {{"version", "1.0"}}}, {"geometricError", 1.5},
               {"root", {{"boundingVolume", box_for(2, 2.0f)}, {"geometricError", 0}, {"refine", "ADD"}, {"content", {{"uri", "c.glb"}}}}}};
  put_file(dir + "/in/sub/ext.json", ext.dump(2));
  ojson ts = {{"asset", {{"version", "1.0"}, {"tilesetVersion", "7"}}},
              {"extensionsUsed", {"3DTILES_content_gltf"}},
              {"geometricError", 100},
              {"root",
               {{"boundingVolume", {{"box", {5, -1, 5, 6, 0, 0, 0, 6, 0, 0, 0, 6}}}},
                {"geometricError", 50},
                {"refine", "REPLACE"},
                {"transform", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 100, 200, 0, 1}},
                {"children",
                 {{{"boundingVolume", box_for(2, 0.0f)}, {"geometricError", 1}, {"content", {{"uri", "tiles/a.b3dm"}}}, {"extras", {{"id", 1}}}},
                  {{"boundingVolume", box_for(3, 1.0f)}, {"geometricError", 1}, {"content", {{"uri", "tiles/b.glb"}}}},
                  {{"boundingVolume", box_for(2, 2.0f)}, {"geometricError", 2}, {"content", {{"uri", "sub/ext.json"}}}}}}}}};
  put_file(dir + "/in/tileset.json", ts.dump(2));
  return dir + "/in/tileset.json";
}

PipelineConfig repack() {
  return parse_config(nlohmann::json::parse(R"({"detector":{"type":"detectors.none"},"merger":{"type":"mergers.none"},
      "packer":{"type":"packers.shelf","gutter":2},"output":{"image_format":"input"}})"), "<test>");
}

std::string tileset_error(const std::string& path) {
  try {
    read_tileset(path);
  } catch (const TilesetError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected TilesetError";
  return "";
}

}  // namespace

TEST(Tiles3d, B3dmTablesSurviveParseAndWrite) {
  const std::string dir = temp_dir();
  build_tileset(dir);
  const auto bytes = file_bytes(dir + "/in/tiles/a.b3dm");
  const B3dm b = parse_b3dm(bytes, "a.b3dm");
  EXPECT_EQ(b.batch_table_json, R"({"name":[]}   )");
  EXPECT_TRUE(is_glb(b.glb));
  const std::string again = write_b3dm(b);
  EXPECT_EQ(again, std::string(bytes.begin(), bytes.end()));
  std::vector<uint8_t> bad = bytes;
  bad[0] = 'x';
  EXPECT_THROW(parse_b3dm(bad, "x"), TilesetError);
  bad = bytes;
  bad.resize(40);
  try {
    parse_b3dm(bad, "short.b3dm");
    ADD_FAILURE();
  } catch (const TilesetError& e) {
    EXPECT_NE(std::string(e.what()).find("short.b3dm: b3dm header says"), std::string::npos) << e.what();
  }
}

TEST(Tiles3d, ReadsEveryContentThroughExternalTilesets) {
  const std::string dir = temp_dir();
  const Tileset t = read_tileset(build_tileset(dir));
  ASSERT_EQ(t.tilesets.size(), 2u);
  ASSERT_EQ(t.contents.size(), 3u);
  EXPECT_EQ(t.contents[0].kind, "b3dm");
  EXPECT_EQ(t.contents[2].tileset, dir + "/in/sub/ext.json");
  EXPECT_TRUE(check_tileset(dir + "/in/tileset.json").empty());
}

TEST(Tiles3d, MissingContentsAndTilesetsAreErrorsNamingTheParent) {
  const std::string dir = temp_dir();
  const std::string ts = build_tileset(dir);
  fs::remove(dir + "/in/sub/c.glb");
  std::string e = tileset_error(ts);
  EXPECT_NE(e.find("sub/c.glb: content not found (named by " + dir + "/in/sub/ext.json)"), std::string::npos) << e;
  fs::remove(dir + "/in/sub/ext.json");
  e = tileset_error(ts);
  EXPECT_NE(e.find("sub/ext.json: content not found (named by " + dir + "/in/tileset.json)"), std::string::npos) << e;
  EXPECT_NE(check_tileset(ts).size(), 0u);
}

TEST(Tiles3d, ProductionRoundTripKeepsStructureTablesAndPositions) {
  const std::string dir = temp_dir();
  const std::string in = build_tileset(dir);
  TilesetRunOptions o;
  o.tileset = in;
  o.output_dir = dir + "/out";
  const nlohmann::json summary = run_tileset(repack(), o);
  EXPECT_EQ(summary["models"].size(), 3u);
  EXPECT_EQ(summary["tilesets"], 2);
  const std::string out = dir + "/out/tileset.json";
  EXPECT_EQ(compare_tilesets(in, out), std::vector<std::string>{});
  EXPECT_EQ(check_tileset(out), std::vector<std::string>{});
  EXPECT_TRUE(fs::exists(dir + "/out/tiles/a.report.json"));
  EXPECT_TRUE(fs::exists(dir + "/out/tileset.summary.json"));
  // The tileset JSON is copied byte for byte when nothing in it has to change.
  EXPECT_EQ(file_bytes(out), file_bytes(in));
  // b3dm tables unchanged, GLB replaced, positions bit-identical.
  const B3dm a = parse_b3dm(file_bytes(dir + "/in/tiles/a.b3dm"), "in"), b = parse_b3dm(file_bytes(dir + "/out/tiles/a.b3dm"), "out");
  EXPECT_EQ(a.feature_table_json, b.feature_table_json);
  EXPECT_EQ(a.batch_table_json, b.batch_table_json);
  EXPECT_NE(a.glb, b.glb);
  for (const char* c : {"tiles/b.glb", "sub/c.glb"}) {
    const GltfModel gi = read_gltf(dir + "/in/" + c), go = read_gltf(dir + "/out/" + c);
    ASSERT_EQ(gi.mesh.faces.size(), go.mesh.faces.size());
    for (size_t f = 0; f < gi.mesh.faces.size(); ++f)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(gi.mesh.corner_position(f, k), go.mesh.corner_position(f, k));
  }
  put_file(dir + "/b.glb", std::string(b.glb.begin(), b.glb.end()));
  TEXDEFRAG_EXPECT_VALID_GLTF((std::vector<std::string>{dir + "/b.glb", dir + "/out/tiles/b.glb", dir + "/out/sub/c.glb"}));
  // A second run into the same folder is refused (the output set does not overwrite a locked run;
  // here the folder exists and the run is complete: it writes again through staging).
  const std::string tools = std::string(source_dir()) + "/tools/node/node_modules/.bin/3d-tiles-tools";
  if (!fs::exists(tools)) {
    std::printf("[  SKIPPED ] 3d-tiles-tools: tools/node/node_modules absent (run scripts/install-npm.sh)\n");
    return;
  }
  const std::string cmd = "'" + tools + "' b3dmToGlb -f -i '" + dir + "/out/tiles/a.b3dm' -o '" + dir + "/a.glb' > '" + dir + "/tools.log' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  EXPECT_EQ(file_bytes(dir + "/a.glb"), b.glb);
  TEXDEFRAG_EXPECT_VALID_GLTF(std::vector<std::string>{dir + "/a.glb"});
}

TEST(Tiles3d, OutputInsideTheInputProductionIsRefused) {
  const std::string dir = temp_dir();
  TilesetRunOptions o;
  o.tileset = build_tileset(dir);
  o.output_dir = dir + "/in/out";
  EXPECT_ANY_THROW(run_tileset(repack(), o));
  EXPECT_FALSE(fs::exists(dir + "/in/out/tileset.json"));
}

namespace {

/// build_tileset plus a level sharing one atlas: shared/s0.glb and shared/s1.glb name the external
/// image shared/atlas.png (each in its own half of it), as Matterport tilesets do.
std::string build_shared_tileset(const std::string& dir) {
  const std::string ts = build_tileset(dir);
  const std::vector<uint8_t> png = png_bytes(dir, 32, 32);
  put_file(dir + "/in/shared/atlas.png", std::string(png.begin(), png.end()));
  ojson j = ojson::parse(file_bytes(ts));
  for (int k = 0; k < 2; ++k) {
    GridData g = grid(2, 2, 3.0f + static_cast<float>(k));
    for (size_t i = 0; i < g.uv.size(); i += 2) g.uv[i] = 0.5f * g.uv[i] + 0.5f * static_cast<float>(k);
    tinygltf::Model m = base_model();
    m.nodes[0].matrix.clear();
    m.meshes[0].primitives.push_back(add_primitive(m, g, add_textured_material(m, {}, "atlas.png")));
    save(m, dir + "/in/shared/s" + std::to_string(k) + ".glb");
    j["root"]["children"].push_back({{"boundingVolume", box_for(2, 3.0f + static_cast<float>(k))},
                                     {"geometricError", 1},
                                     {"content", {{"uri", "shared/s" + std::to_string(k) + ".glb"}}}});
  }
  put_file(ts, j.dump(2));
  return ts;
}

/// {relative path: bytes} of every file under `dir` except run reports and summaries (they hold times).
std::map<std::string, std::vector<uint8_t>> output_files(const std::string& dir) {
  std::map<std::string, std::vector<uint8_t>> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || name.find(".report.json") != std::string::npos ||
        name.find(".summary.json") != std::string::npos || name.front() == '.')
      continue;
    out[fs::relative(e.path(), dir).generic_string()] = file_bytes(e.path().string());
  }
  return out;
}

std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an error";
  return "";
}

}  // namespace

// The batch form of a tileset production: plan_tileset's models (contents sharing an atlas stay
// one model), each run alone (TilesetRunOptions::contents), then finish_tileset: the same files as
// one whole run.
TEST(Tiles3d, ModelsRunOneByOneThenFinishedEqualTheWholeRun) {
  const std::string dir = temp_dir();
  const std::string in = build_shared_tileset(dir);
  const TilesetPlan plan = plan_tileset(in);
  ASSERT_EQ(plan.models.size(), 4u);
  EXPECT_EQ(plan.models[0].contents, std::vector<std::string>{"tiles/a.b3dm"});
  EXPECT_EQ(plan.models[3].contents, (std::vector<std::string>{"shared/s0.glb", "shared/s1.glb"}));
  EXPECT_EQ(plan.models[3].files, (std::vector<std::string>{dir + "/in/shared/s0.glb", dir + "/in/shared/s1.glb",
                                                            dir + "/in/shared/atlas.png"}));
  EXPECT_EQ(plan.models[3].parent, in);
  EXPECT_TRUE(plan.copies.empty());

  TilesetRunOptions whole;
  whole.tileset = in;
  whole.output_dir = dir + "/whole";
  run_tileset(repack(), whole);

  const std::string out = dir + "/parts";
  TilesetRunOptions o;
  o.tileset = in;
  o.output_dir = out;
  // Half of a shared atlas, or a name that is no content: errors naming the tileset, nothing written.
  o.contents = {"shared/s1.glb"};
  std::string e = error_of([&] { run_tileset(repack(), o); });
  EXPECT_NE(e.find(in + ": contents shared/s0.glb, shared/s1.glb share an atlas"), std::string::npos) << e;
  o.contents = {"tiles/nope.glb"};
  e = error_of([&] { run_tileset(repack(), o); });
  EXPECT_NE(e.find("'tiles/nope.glb' is not a glTF or b3dm content"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(out + "/tileset.json"));
  for (size_t m = 0; m < plan.models.size(); ++m) {
    o.contents = plan.models[m].contents;
    const nlohmann::json s = run_tileset(repack(), o);
    ASSERT_EQ(s["reports"].size(), 1u);
    EXPECT_EQ(s["reports"][0]["input_stats"]["faces"], s["models"][0]["faces"]);
    EXPECT_FALSE(fs::exists(out + "/tileset.json"));  // only finish writes the tileset JSONs
    if (m == 0) {
      e = error_of([&] { finish_tileset(in, out); });
      EXPECT_NE(e.find(out + "/tiles/b.glb: output of content tiles/b.glb (named by " + in + ") is missing"),
                std::string::npos)
          << e;
    }
  }
  EXPECT_TRUE(fs::exists(out + "/shared/s0.report.json"));
  const std::vector<std::string> written = finish_tileset(in, out);
  EXPECT_EQ(written, (std::vector<std::string>{"tileset.json", "sub/ext.json"}));
  EXPECT_EQ(output_files(out), output_files(dir + "/whole"));
  EXPECT_EQ(compare_tilesets(in, out + "/tileset.json"), std::vector<std::string>{});
  EXPECT_EQ(check_tileset(out + "/tileset.json"), std::vector<std::string>{});
}

// Tile transforms (through external tilesets) and the glTF y-up to z-up turn are applied for
// measuring only (GltfInput::outer_linear, docs/io.md "Node transforms"): a root transform that
// scales the tile z (up) axis by 3 stretches glTF y (its up axis) by 3 in what the stages measure;
// an external tileset saying asset.gltfUpAxis "Z" stretches glTF z instead; the files written keep
// their stored positions bit for bit.
TEST(Tiles3d, TileTransformsAreAppliedForMeasuringOnly) {
  const std::string dir = temp_dir();
  put_file(dir + "/in/b.glb", grid_glb(dir, 2, 1.0f));
  put_file(dir + "/in/sub/c.glb", grid_glb(dir, 2, 2.0f));
  const ojson box = {{"box", {0, 0, 0, 100, 0, 0, 0, 100, 0, 0, 0, 100}}};
  ojson ext = {{"asset", {{"version", "1.0"}, {"gltfUpAxis", "Z"}}}, {"geometricError", 1},
               {"root", {{"boundingVolume", box}, {"geometricError", 0}, {"content", {{"uri", "c.glb"}}}}}};
  put_file(dir + "/in/sub/ext.json", ext.dump(2));
  const double c = std::cos(0.5), s = std::sin(0.5);  // a rigid turn about z on the child tile
  ojson ts = {{"asset", {{"version", "1.0"}}}, {"geometricError", 10},
              {"root",
               {{"boundingVolume", box}, {"geometricError", 5}, {"refine", "ADD"},
                {"transform", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 3, 0, 100, 200, 300, 1}},
                {"children",
                 {{{"boundingVolume", box}, {"geometricError", 1}, {"content", {{"uri", "b.glb"}}},
                   {"transform", {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}},
                  {{"boundingVolume", box}, {"geometricError", 1}, {"content", {{"uri", "sub/ext.json"}}}}}}}}};
  put_file(dir + "/in/tileset.json", ts.dump(2));

  const Tileset t = read_tileset(dir + "/in/tileset.json");
  ASSERT_EQ(t.contents.size(), 2u);
  // glTF (x, y, z) -> tile (x, -z, y), turned about z, then tile z scaled by 3.
  Mat3 turn_y, turn_z, scale_z = Mat3::Identity();
  turn_y << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  turn_z << c, -s, 0, s, c, 0, 0, 0, 1;
  scale_z(2, 2) = 3;
  EXPECT_LT((t.contents[0].measure_linear - scale_z * turn_z * turn_y).norm(), 1e-15);
  EXPECT_LT((t.contents[1].measure_linear - scale_z).norm(), 1e-15);  // gltfUpAxis Z: no turn

  const GltfModel plain_b = read_gltf(dir + "/in/b.glb"), plain_c = read_gltf(dir + "/in/sub/c.glb");
  const GltfModel seen_b = read_gltf({{dir + "/in/b.glb", {}, "", t.contents[0].measure_linear}});
  const GltfModel seen_c = read_gltf({{dir + "/in/sub/c.glb", {}, "", t.contents[1].measure_linear}});
  ASSERT_EQ(seen_b.mesh.positions.size(), plain_b.mesh.positions.size());
  EXPECT_EQ(seen_b.positions_stretched, seen_b.mesh.positions.size());
  for (size_t i = 0; i < plain_b.mesh.positions.size(); ++i) {
    const Vec3 p = plain_b.mesh.positions[i], q = plain_c.mesh.positions[i];
    EXPECT_LT((seen_b.mesh.positions[i] - Vec3(p.x(), 3 * p.y(), p.z())).norm(), 1e-12) << i;  // glTF y is up
    EXPECT_LT((seen_c.mesh.positions[i] - Vec3(q.x(), q.y(), 3 * q.z())).norm(), 1e-12) << i;  // glTF z is up
  }

  TilesetRunOptions o;
  o.tileset = dir + "/in/tileset.json";
  o.output_dir = dir + "/out";
  run_tileset(repack(), o);
  for (const char* name : {"b", "sub/c"}) {
    const nlohmann::json report = nlohmann::json::parse(file_bytes(dir + "/out/" + name + ".report.json"));
    EXPECT_EQ(report["stages"]["read"]["positions_stretched"], seen_b.mesh.positions.size()) << name;
    // Written: the stored positions, bit for bit.
    const GltfModel gi = read_gltf(dir + "/in/" + name + ".glb"), go = read_gltf(dir + "/out/" + name + ".glb");
    ASSERT_EQ(gi.mesh.faces.size(), go.mesh.faces.size());
    for (size_t f = 0; f < gi.mesh.faces.size(); ++f)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(gi.mesh.corner_position(f, k), go.mesh.corner_position(f, k));
  }
  EXPECT_EQ(compare_tilesets(dir + "/in/tileset.json", dir + "/out/tileset.json"), std::vector<std::string>{});

  ts["root"]["transform"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0};  // 15 numbers
  put_file(dir + "/in/tileset.json", ts.dump(2));
  const std::string e = tileset_error(dir + "/in/tileset.json");
  EXPECT_NE(e.find("tileset.json: a tile's transform is not an array of 16 numbers"), std::string::npos) << e;
}
