// Contracts the framework checks after each stage (issue 11): a detector's regions partition the
// textured faces, packed charts overlap no more than the input's, every output UV lies on its page,
// and stages cannot write the framework's report keys. Each is shown with a stage that breaks it.
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"
#include "texdefrag/util/paths.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

/// A detector that puts every textured face in region 0 but declares `num_regions` = 2 (region 1 empty).
class EmptyRegionDetector final : public Detector {
 public:
  void detect(StageContext& ctx) override {
    ctx.regions.face_region.assign(ctx.mesh->faces.size(), -1);
    for (size_t f = 0; f < ctx.mesh->faces.size(); ++f)
      if (ctx.mesh->faces[f].page != kNoPage) ctx.regions.face_region[f] = 0;
    ctx.regions.num_regions = 2;
  }
};

/// A packer that stacks every chart at the origin of one page (charts overlap).
class StackingPacker final : public Packer {
 public:
  void pack(StageContext& ctx) override {
    const Atlas& a = ctx.atlas;
    std::vector<Vec2> lo(static_cast<size_t>(a.num_charts), Vec2(1e300, 1e300));
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] >= 0)
        for (int w : a.face_wedge[f]) {
          Vec2& l = lo[static_cast<size_t>(a.face_chart[f])];
          l = l.cwiseMin(a.wedge_uv[static_cast<size_t>(w)]);
        }
    ctx.layout.pages = {{256, 256}};
    ctx.layout.chart_page.assign(static_cast<size_t>(a.num_charts), 0);
    ctx.layout.wedge_uv = a.wedge_uv;
    for (size_t f = 0; f < a.face_chart.size(); ++f)
      if (a.face_chart[f] >= 0)
        for (int w : a.face_wedge[f])
          ctx.layout.wedge_uv[static_cast<size_t>(w)] = a.wedge_uv[static_cast<size_t>(w)] - lo[static_cast<size_t>(a.face_chart[f])];
  }
};

/// A detector that is fine but writes the framework's `time_s` into its report node.
class ForgingDetector final : public Detector {
 public:
  void detect(StageContext& ctx) override {
    ctx.regions.face_region.assign(ctx.mesh->faces.size(), -1);
    for (size_t f = 0; f < ctx.mesh->faces.size(); ++f)
      if (ctx.mesh->faces[f].page != kNoPage) ctx.regions.face_region[f] = 0;
    ctx.regions.num_regions = 1;
    (*ctx.report)["time_s"] = 0.0;
  }
};

template <class S>
void register_once(const std::string& name, StageKind kind) {
  Registry& r = Registry::instance();
  r.load_plugins();
  if (r.find(name)) return;
  StageInfo i;
  i.name = name;
  i.kind = kind;
  i.description = "breaks a contract (test)";
  i.doc = "tests/pipeline/test_pipeline_contracts.cpp";
  i.create = [] { return std::make_unique<S>(); };
  r.add(i, "test_pipeline_contracts");
}

std::string model(const std::string& dir) {
  TexturedMesh m = texdefrag::testing::fragmented_grid_mesh(4, 3, 128, dir + "/page.png");
  texdefrag::testing::write_surface_texture(m, 0, dir + "/page.png");
  write_obj(m, dir + "/small.obj");
  return dir + "/small.obj";
}

std::string run_error(const json& cfg, const std::string& dir) {
  RunOptions ro;
  ro.input = model(dir);
  ro.output_dir = dir + "/out";
  try {
    run_pipeline(parse_config(cfg, "<test>"), ro);
  } catch (const StageError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PipelineContracts, DetectorRegionsMustPartitionTheTexturedFaces) {
  register_once<EmptyRegionDetector>("detectors.test_empty_region", StageKind::Detector);
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string e = run_error({{"detector", {{"type", "detectors.test_empty_region"}}}}, dir);
  EXPECT_NE(e.find("detectors.test_empty_region: region 1 has no face"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(dir + "/out/small.obj"));
}

TEST(PipelineContracts, PackedChartsMayNotOverlapMoreThanTheInput) {
  register_once<StackingPacker>("packers.test_stacking", StageKind::Packer);
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string e = run_error({{"packer", {{"type", "packers.test_stacking"}}}}, dir);
  EXPECT_NE(e.find("packers.test_stacking: the packed charts overlap in"), std::string::npos) << e;
  EXPECT_NE(e.find("the input only in 0"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(dir + "/out/small.obj"));
}

TEST(PipelineContracts, StagesCannotWriteTheFrameworksReportKeys) {
  register_once<ForgingDetector>("detectors.test_forging", StageKind::Detector);
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string e = run_error({{"detector", {{"type", "detectors.test_forging"}}}}, dir);
  EXPECT_NE(e.find("detectors.test_forging: wrote report key 'time_s'"), std::string::npos) << e;
}

TEST(PipelineContracts, TheReportNamesEachFigureOnce) {
  const std::string dir = texdefrag::testing::temp_dir();
  RunOptions ro;
  ro.input = model(dir);
  ro.output_dir = dir + "/out";
  const json cfg = {{"detector", {{"type", "detectors.region_growing"}}}, {"merger", {{"type", "mergers.arap"}}},
                    {"packer", {{"type", "packers.square_tetris"}}}};
  const json report = run_pipeline(parse_config(cfg, "<test>"), ro);
  const json& m = report["stages"]["mergers.arap"];
  for (const char* k : {"charts_in", "charts_out", "distortion_arap", "flipped_faces", "time_s"}) EXPECT_TRUE(m.contains(k)) << k;
  for (const char* k : {"distortion_out", "flipped_out", "time_ms"}) EXPECT_FALSE(m.contains(k)) << k;
  EXPECT_FALSE(report["stages"]["packers.square_tetris"].contains("time_ms"));
  EXPECT_EQ(report["stages"]["packers.square_tetris"]["uv_overlap_pairs"], 0);
  EXPECT_EQ(report["input_stats"]["uv_overlap_pairs"], 0);
  // Every output UV inside [0, 1].
  const TexturedMesh out = read_obj(report["output"].get<std::string>());
  for (const Vec2& t : out.texcoords) {
    EXPECT_GE(t.x(), 0.0);
    EXPECT_LE(t.x(), 1.0);
    EXPECT_GE(t.y(), 0.0);
    EXPECT_LE(t.y(), 1.0);
  }
}

// Issue 11, case 3: a chart at u = 37..38 (the MTL default is repeat) came out one flat colour.
TEST(PipelineTexture, RepackKeepsTheColoursOfAChartFarOutsideTheUnitSquare) {
  const std::string dir = texdefrag::testing::temp_dir();
  Image img;  // 33 x 31 = 1,023 texels, each its own colour
  img.width = 33;
  img.height = 31;
  img.channels = 3;
  img.pixels.resize(33 * 31 * 3);
  for (int y = 0; y < 31; ++y)
    for (int x = 0; x < 33; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = static_cast<uint8_t>(x * 7);
      p[1] = static_cast<uint8_t>(y * 8);
      p[2] = static_cast<uint8_t>((x * 5 + y * 3) % 256);
    }
  write_image(dir + "/tex.png", img, ImageFormat::Png);
  for (const std::string clamp : {"", "-clamp on "}) {
    SCOPED_TRACE(clamp);
    std::ofstream(dir + "/m.mtl") << "newmtl a\nmap_Kd " << clamp << "tex.png\n";
    std::ofstream(dir + "/m.obj") << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                     "vt 37 0\nvt 38 0\nvt 38 1\nvt 37 1\nusemtl a\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    RunOptions ro;
    ro.input = dir + "/m.obj";
    ro.output_dir = dir + "/out" + (clamp.empty() ? "" : "_clamp");
    const json report = run_pipeline(load_config(std::string(source_dir()) + "/configs/repack.json"), ro);
    const TexturedMesh out = read_obj(report["output"].get<std::string>());
    const Image page = read_image(out.pages[0].image_path);
    double u0 = 1, v1 = 0;
    for (const Vec2& t : out.texcoords) {
      u0 = std::min(u0, t.x());
      v1 = std::max(v1, t.y());
    }
    const int x0 = static_cast<int>(std::lround(u0 * page.width)), y0 = static_cast<int>(std::lround((1 - v1) * page.height));
    size_t same = 0, total = 0;
    for (int y = 0; y < 31; ++y)
      for (int x = 0; x < 33; ++x) {
        // repeat: the page itself; clamp: u >= 1 everywhere, so the right column
        const uint8_t* want = img.at(clamp.empty() ? x : 32, y);
        same += std::equal(want, want + 3, page.at(x0 + x, y0 + y));
        ++total;
      }
    EXPECT_EQ(same, total);
  }
}
