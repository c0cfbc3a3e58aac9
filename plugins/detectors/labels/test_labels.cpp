// Tests of detectors.labels: label file formats, errors naming file and line, intersection.
#include "common/test_meshes.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace texdefrag;
namespace tmesh = texdefrag::detectors::testmesh;

namespace {
constexpr const char* kL = "detectors.labels";

std::string write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const TexturedMesh& m, const json& opts) {
  try {
    tmesh::run_detector(kL, m, opts);
  } catch (const StageError& e) {
    return e.what();
  } catch (const std::invalid_argument& e) {  // refused by the option declarations (typed options)
    return e.what();
  }
  return "";
}
}  // namespace

TEST(DetectorsLabels, ReadsTextAndJsonLabels) {
  const TexturedMesh m = texdefrag::testing::grid_mesh(2, 1, 64, "p.png");  // 4 faces
  const std::string dir = texdefrag::testing::temp_dir();
  const auto t = tmesh::run_detector(kL, m, {{"path", write(dir + "/l.txt", "# classes\n7\n7\n3000000\n\n7\n")}});
  EXPECT_EQ(t.regions.num_regions, 2);
  EXPECT_EQ(t.regions.face_region, (std::vector<int>{0, 0, 1, 0}));  // largest label first
  const auto j = tmesh::run_detector(kL, m, {{"path", write(dir + "/l.json", R"({"face_labels": [1, 2, 2, 5]})")}});
  EXPECT_EQ(j.regions.face_region, (std::vector<int>{1, 0, 0, 2}));
  EXPECT_EQ(j.regions.num_regions, 3);
}

TEST(DetectorsLabels, ErrorsNameTheFileAndLine) {
  TexturedMesh m = texdefrag::testing::grid_mesh(2, 1, 64, "p.png");
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string bad = write(dir + "/bad.txt", "1\n2\nwall\n4\n");
  EXPECT_NE(error_of(m, {{"path", bad}}).find(bad + ":3: expected one integer label, got 'wall'"), std::string::npos)
      << error_of(m, {{"path", bad}});
  const std::string few = write(dir + "/few.txt", "1\n2\n3\n");
  EXPECT_NE(error_of(m, {{"path", few}}).find("has 3 labels, the mesh has 4 faces"), std::string::npos);
  const std::string many = write(dir + "/many.txt", "1\n2\n3\n4\n5\n");
  EXPECT_NE(error_of(m, {{"path", many}}).find(many + ":5: more labels"), std::string::npos);
  const std::string big = write(dir + "/big.txt", "1\n2\n99999999999\n4\n");
  EXPECT_NE(error_of(m, {{"path", big}}).find(big + ":3:"), std::string::npos);
  const std::string js = write(dir + "/bad.json", R"({"face_labels": [1, 2.5, 3, 4]})");
  EXPECT_NE(error_of(m, {{"path", js}}).find("face_labels[1] = 2.5 is not an integer"), std::string::npos);
  const std::string malformed = write(dir + "/m.json", R"({"face_labels": [1, 2,)");
  EXPECT_NE(error_of(m, {{"path", malformed}}).find("malformed JSON"), std::string::npos);
  const std::string neg = write(dir + "/neg.txt", "1\n-1\n1\n1\n");
  EXPECT_NE(error_of(m, {{"path", neg}}).find(neg + ":2: face 1"), std::string::npos);
  EXPECT_NE(error_of(m, {{"path", dir + "/absent.txt"}}).find("'path' = \"" + dir + "/absent.txt\": no such file"), std::string::npos);
  EXPECT_NE(error_of(m, json::object()).find("'path' is required"), std::string::npos);
  // A negative label on an untextured face is fine: it stays outside every region.
  m.faces[1].page = kNoPage;
  const auto ok = tmesh::run_detector(kL, m, {{"path", neg}});
  EXPECT_EQ(ok.regions.face_region, (std::vector<int>{0, -1, 0, 0}));
}

TEST(DetectorsLabels, IntersectionWithRegionGrowingSplitsOneLabelByPlane) {
  const tmesh::Case c = tmesh::corner_chart_case();  // wall 0 and roof 1
  const std::string dir = texdefrag::testing::temp_dir();
  std::string all;
  for (size_t f = 0; f < c.mesh.faces.size(); ++f) all += "4\n";
  const std::string path = write(dir + "/one.txt", all);
  const auto plain = tmesh::run_detector(kL, c.mesh, {{"path", path}});
  EXPECT_EQ(plain.regions.num_regions, 1);
  const auto inter = tmesh::run_detector(kL, c.mesh, {{"path", path}, {"intersect_with", "detectors.region_growing"}});
  EXPECT_EQ(inter.regions.num_regions, 2);
  for (size_t f = 0; f < c.truth.size(); ++f)
    EXPECT_EQ(inter.regions.face_region[f] == inter.regions.face_region[0], c.truth[f] == c.truth[0]);
  EXPECT_EQ(inter.report["intersect_regions"], 2);
  EXPECT_NE(error_of(c.mesh, {{"path", path}, {"intersect_with", "detectors.region_growin"}}).find("region_growing"),
            std::string::npos);
  EXPECT_THROW(tmesh::run_detector(kL, c.mesh, {{"path", path}, {"intersect_with", kL}}), StageError);
}
