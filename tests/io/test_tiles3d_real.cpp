// The real Matterport tileset ../shared/data/tiles3d_cedar_creek/mesh_tiles/3.json (levels 0-3,
// external tilesets, Draco GLBs, KTX2 pages with JPEG stand-ins) as one production: repack round
// trip (structure identical, positions bit-identical, texels copied), then best.json with pages in
// the input's format (every model defragmented, no face lost, page bytes <= input per model).
// Validators: the Khronos glTF validator on every GLB written. Slow (minutes): label `slow`.
#include "gltf_test_util.h"

#include "texdefrag/io/tiles3d.h"
#include "texdefrag/pipeline/pipeline.h"

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;
using namespace texdefrag;
using namespace texdefrag::gltf_test;

namespace {

nlohmann::json run(const std::string& tileset, const std::string& config, const std::vector<std::string>& sets,
                   const std::string& out) {
  TilesetRunOptions o;
  o.tileset = tileset;
  o.output_dir = out;
  return run_tileset(load_config(std::string(source_dir()) + "/configs/" + config, sets), o);
}

std::vector<std::string> written_glbs(const std::string& out) {
  std::vector<std::string> v;
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.path().extension() == ".glb") v.push_back(e.path().string());
  std::sort(v.begin(), v.end());
  return v;
}

nlohmann::json load(const std::string& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(Tiles3dReal, CedarCreekRepackRoundTripIsExact) {
  TEXDEFRAG_REQUIRE_DATA(ts, "tiles3d_cedar_creek/mesh_tiles/3.json");
  const std::string out = texdefrag::testing::temp_dir();
  const nlohmann::json s = run(ts, "repack.json", {}, out);
  EXPECT_EQ(compare_tilesets(ts, out + "/3.json"), std::vector<std::string>{});
  EXPECT_EQ(check_tileset(out + "/3.json").size(), check_tileset(ts).size());
  const Tileset in = read_tileset(ts);
  for (const TilesetContent& c : in.contents) {
    const std::string o = out + "/" + fs::path(c.path).lexically_relative(fs::path(ts).parent_path()).generic_string();
    GltfReadOptions ro;
    ro.read_page_sizes = false;
    const GltfModel a = read_gltf({{c.path, {}, ""}}, ro), b = read_gltf({{o, {}, ""}}, ro);
    ASSERT_EQ(a.mesh.faces.size(), b.mesh.faces.size()) << c.path;
    for (size_t f = 0; f < a.mesh.faces.size(); ++f)
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(std::memcmp(a.mesh.corner_position(f, k).data(), b.mesh.corner_position(f, k).data(), 24), 0) << o << " face " << f;
  }
  for (const auto& m : s["models"]) {
    const nlohmann::json r = load(out + "/" + m["report"].get<std::string>());
    // Repacking copies every texel: this producer's input charts overlap in UV space and hold
    // zero-UV-area faces (10,301 in lod3_room2), which are copied too (a zero-area face keeps its
    // point's texels and never overwrites a real face's border; before, 25,281 texels of lod3_room2
    // took such a face's centroid colour).
    const auto& t = r["stages"]["texture.resample"];
    EXPECT_EQ(t["faces_resampled"].get<size_t>(), 0u) << m["report"];
    EXPECT_EQ(t["texels_copied"].get<size_t>(), t["texels_written"].get<size_t>()) << m["report"];
    EXPECT_EQ(r["input_stats"]["faces"], r["output_stats"]["faces"]);
  }
  TEXDEFRAG_EXPECT_VALID_GLTF(written_glbs(out));
}

TEST(Tiles3dReal, CedarCreekBestDefragmentsEveryModel) {
  TEXDEFRAG_REQUIRE_DATA(ts, "tiles3d_cedar_creek/mesh_tiles/3.json");
  const std::string out = texdefrag::testing::temp_dir();
  const nlohmann::json s = run(ts, "best.json", {"output.image_format=input"}, out);
  EXPECT_EQ(compare_tilesets(ts, out + "/3.json"), std::vector<std::string>{});
  for (const auto& m : s["models"]) {
    EXPECT_LT(m["charts_out"].get<int>(), m["charts_in"].get<int>()) << m["report"];
    EXPECT_LE(m["page_bytes_out"].get<size_t>(), m["page_bytes_in"].get<size_t>()) << m["report"];
    const nlohmann::json r = load(out + "/" + m["report"].get<std::string>());
    EXPECT_EQ(r["input_stats"]["faces"], r["output_stats"]["faces"]);
  }
  TEXDEFRAG_EXPECT_VALID_GLTF(written_glbs(out));
}
