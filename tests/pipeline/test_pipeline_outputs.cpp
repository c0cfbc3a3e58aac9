// What a run writes, through the one write service (io/output_set.h): never an input file, only
// under the output folder, the whole set or nothing, one run per folder. Cases 1, 2 and 4 of
// issue 11 (a hostile user's session).
#include "texdefrag/io/obj.h"
#include "texdefrag/io/output_set.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A small fragmented model in DIR/in: model.obj, model.mtl, page.png.
std::string small_model(const std::string& dir) {
  fs::create_directories(dir + "/in");
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(4, 3, 128, dir + "/in/page.png");
  texdefrag::testing::write_surface_texture(m, 0, dir + "/in/page.png");
  write_obj(m, dir + "/in/model.obj");
  return dir + "/in/model.obj";
}

/// Every file under `dir` (relative names), sorted; hidden files included.
std::vector<std::string> tree(const std::string& dir) {
  std::vector<std::string> v;
  if (!fs::exists(dir)) return v;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    v.push_back(fs::relative(e.path(), dir).string());
  std::sort(v.begin(), v.end());
  return v;
}

json config_with(const json& detector = {{"type", "detectors.none"}}) {
  return {{"detector", detector}, {"merger", {{"type", "mergers.none"}}}, {"packer", {{"type", "packers.shelf"}}}};
}

/// The message of what run_pipeline throws, or "" when it succeeds.
std::string run_error(const PipelineConfig& cfg, const std::string& input, const std::string& out) {
  RunOptions ro;
  ro.input = input;
  ro.output_dir = out;
  try {
    run_pipeline(cfg, ro);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// Issue 11, case 1: `--set detector.write_colored=<the input .obj>` overwrote the input OBJ and MTL.
TEST(PipelineOutputs, AStageSideOutputCannotOverwriteTheInput) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  const std::string obj_before = slurp(model), mtl_before = slurp(dir + "/in/model.mtl");
  for (const std::string& target : {model, std::string("../in/model.obj")}) {
    SCOPED_TRACE(target);
    const json cfg = config_with({{"type", "detectors.angle_growing"}, {"write_colored", target}});
    std::string e;
    try {
      e = run_error(parse_config(cfg, "<test>"), model, dir + "/out");
    } catch (const ConfigError& c) {
      e = c.what();  // refused before the run: also fine
    }
    EXPECT_NE(e.find("write_colored"), std::string::npos) << e;
    EXPECT_EQ(slurp(model), obj_before);
    EXPECT_EQ(slurp(dir + "/in/model.mtl"), mtl_before);
    EXPECT_EQ(tree(dir + "/in"), (std::vector<std::string>{"model.mtl", "model.obj", "page.png"}));
    EXPECT_EQ(tree(dir + "/out"), std::vector<std::string>{});
  }
  // A plain name is written with the run's other outputs.
  const json cfg = config_with({{"type", "detectors.angle_growing"}, {"write_colored", "regions.obj"}, {"write_labels", "regions.txt"}});
  EXPECT_EQ(run_error(parse_config(cfg, "<test>"), model, dir + "/out"), "");
  EXPECT_EQ(tree(dir + "/out"), (std::vector<std::string>{"model.mtl", "model.obj", "model.report.json", "model_page0.png",
                                                          "regions.mtl", "regions.obj", "regions.txt", "regions_palette.png"}));
}

// Issue 11, case 1: an input OBJ whose mtllib names a file in the output folder had that MTL
// overwritten by the run's own MTL.
TEST(PipelineOutputs, AnInputMtlInsideTheOutputFolderIsRefusedBeforeAnyWrite) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  fs::create_directories(dir + "/out");
  fs::rename(dir + "/in/model.mtl", dir + "/out/model.mtl");
  std::string obj = slurp(model);
  const size_t at = obj.find("mtllib model.mtl");
  ASSERT_NE(at, std::string::npos);
  obj.replace(at, 16, "mtllib ../out/model.mtl");
  std::ofstream(model, std::ios::binary) << obj;
  // the MTL's map_Kd is relative to its own folder
  std::string mtl = slurp(dir + "/out/model.mtl");
  mtl.replace(mtl.find("map_Kd page.png"), 15, "map_Kd ../in/page.png");
  std::ofstream(dir + "/out/model.mtl", std::ios::binary) << mtl;
  ASSERT_NO_THROW(read_obj(model));

  const std::string e = run_error(load_config(std::string(source_dir()) + "/configs/repack.json"), model, dir + "/out");
  EXPECT_NE(e.find(dir + "/out/model.mtl: refusing to write onto the input file"), std::string::npos) << e;
  EXPECT_NE(e.find("referenced by " + model), std::string::npos) << e;
  EXPECT_EQ(slurp(dir + "/out/model.mtl"), mtl);
  EXPECT_EQ(tree(dir + "/out"), std::vector<std::string>{"model.mtl"});
  EXPECT_NO_THROW(read_obj(model));
}

// Issue 11, case 2: `--set output.name=../in/copy` wrote four files into the input's folder;
// an absolute name wrote anywhere.
TEST(PipelineOutputs, OutputNameIsAFileStem) {
  const std::string dir = texdefrag::testing::temp_dir();
  for (const std::string& name : {std::string("../in/copy"), std::string("../in/model"), dir + "/abs", std::string("a/b")}) {
    SCOPED_TRACE(name);
    try {
      load_config(std::string(source_dir()) + "/configs/repack.json", {"output.name=" + name});
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("output.name: '" + name + "'"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(load_config(std::string(source_dir()) + "/configs/repack.json", {"output.name=copy"}));
}

// Issue 11, case 4: each file was renamed on its own, so a failure late in the write left pages
// and an MTL under their final names without an OBJ or report.
TEST(PipelineOutputs, AFailedWriteLeavesNoFileUnderAFinalName) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  fs::create_directories(dir + "/out/model.report.json");  // a folder where the last file goes
  const std::string e = run_error(load_config(std::string(source_dir()) + "/configs/repack.json"), model, dir + "/out");
  EXPECT_NE(e.find("model.report.json"), std::string::npos) << e;
  EXPECT_EQ(tree(dir + "/out"), std::vector<std::string>{"model.report.json"});
}

// Issue 11, case 4: two runs into one folder once paired one run's OBJ with the other's page.
TEST(PipelineOutputs, TwoRunsIntoOneFolderExcludeEachOther) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string model = small_model(dir);
  const PipelineConfig cfg = load_config(std::string(source_dir()) + "/configs/repack.json");
  {
    OutputSet other_run(dir + "/out", {});
    const std::string e = run_error(cfg, model, dir + "/out");
    EXPECT_NE(e.find("in use by another texdefrag run"), std::string::npos) << e;
    EXPECT_NE(e.find(dir + "/out/.texdefrag.lock"), std::string::npos) << e;
  }
  EXPECT_EQ(tree(dir + "/out"), std::vector<std::string>{});
  EXPECT_EQ(run_error(cfg, model, dir + "/out"), "");
  EXPECT_EQ(tree(dir + "/out"), (std::vector<std::string>{"model.mtl", "model.obj", "model.report.json", "model_page0.png"}));
}
