// glTF reader and writer on the real 3D Tiles content of ../shared/data/tiles3d_cedar_creek
// (Matterport, Draco geometry, KTX2 pages with full-resolution JPEGs beside them): every level's
// GLBs, grouped by shared atlas, read and written back unchanged (skips when the data is absent).
#include "gltf_test_util.h"

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::gltf_test;

namespace {

std::vector<GltfInput> level_glbs(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".glb") names.push_back(e.path().string());
  std::sort(names.begin(), names.end());
  std::vector<GltfInput> in;
  for (const auto& n : names) in.push_back({n, {}, ""});
  return in;
}

}  // namespace

TEST(GltfReal, CedarCreekGroupsRoundTripWithPositionsBitIdentical) {
  TEXDEFRAG_REQUIRE_DATA(root, "tiles3d_cedar_creek/mesh_tiles");
  const std::string out = texdefrag::testing::temp_dir();
  std::vector<std::string> written;
  for (int level = 0; level <= 3; ++level) {
    const std::string dir = root + "/" + std::to_string(level);
    const std::vector<GltfInput> in = level_glbs(dir);
    ASSERT_FALSE(in.empty()) << dir;
    const auto groups = gltf_shared_image_groups(in);
    // Level 0 shares one atlas (lod0_000) across all its GLBs; deeper levels have one atlas each.
    if (level == 0) EXPECT_EQ(groups.size(), 1u);
    else EXPECT_EQ(groups.size(), in.size());
    size_t faces = 0;
    for (const auto& gi : groups) {
      std::vector<GltfInput> group;
      for (size_t i : gi) group.push_back(in[i]);
      const GltfModel g = read_gltf(group);
      ASSERT_EQ(g.mesh.pages.size(), 1u) << group.front().path;
      EXPECT_FALSE(g.page_source[0].replaces_ktx2.empty());
      EXPECT_EQ(fs::path(g.page_source[0].image_file).extension(), ".jpg");
      EXPECT_EQ(g.stats["draco_primitives"], g.stats["triangle_primitives"]);
      faces += g.mesh.faces.size();
      GltfOutputPaths p;
      p.map_path = [&](const std::string& f) { return (fs::path(out) / fs::path(f).lexically_relative(root)).string(); };
      for (const auto& i : group) p.documents.push_back(p.map_path(i.path));
      std::vector<EncodedPage> pages = {{"image/jpeg", file_bytes(g.page_source[0].image_file)}};
      const GltfOutput o = write_gltf(g, g.mesh, pages, p);
      for (size_t i = 0; i < o.documents.size(); ++i) put_file(p.documents[i], o.documents[i]);
      for (const auto& f : o.files) put_file(f.path, f.bytes);
      std::vector<GltfInput> back_in;
      for (const auto& d : p.documents) back_in.push_back({d, {}, ""});
      const GltfModel back = read_gltf(back_in);
      ASSERT_EQ(back.mesh.faces.size(), g.mesh.faces.size());
      for (size_t f = 0; f < g.mesh.faces.size(); ++f)
        for (int k = 0; k < 3; ++k)
          ASSERT_EQ(std::memcmp(g.mesh.corner_position(f, k).data(), back.mesh.corner_position(f, k).data(), 24), 0)
              << group.front().path << " face " << f;
      // The page is the JPEG, copied byte for byte by this identity write.
      EXPECT_EQ(file_bytes(back.page_source[0].image_file), pages[0].bytes);
      written.push_back(p.documents.front());
    }
    std::printf("level %d: %zu GLBs, %zu groups, %zu faces\n", level, in.size(), groups.size(), faces);
  }
  TEXDEFRAG_EXPECT_VALID_GLTF(written);
}
