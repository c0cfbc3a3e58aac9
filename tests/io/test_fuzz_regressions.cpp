// Inputs the format fuzzers (tests/fuzz/fuzz_gltf, fuzz_osgb, fuzz_tiles3d) found, each rebuilt
// here in its smallest form: every one is now an error naming the file (or a listed problem of
// check_tileset), where it was undefined behaviour, a read of freed memory or an exception that
// named nothing.
#include "texdefrag/io/gltf.h"
#include "texdefrag/io/osgb.h"
#include "texdefrag/io/tiles3d.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <string>
#include <vector>

using namespace texdefrag;

namespace {

std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

void put(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

/// A .gltf with one triangle (positions in a data URI) whose primitive JSON is `primitive`.
std::string gltf_with_primitive(const std::string& primitive) {
  // 3 float VEC3 positions: (0,0,0) (1,0,0) (0,1,0), base64.
  return R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,)"
         R"(AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],)"
         R"("bufferViews":[{"buffer":0,"byteLength":36}],)"
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],)"
         R"("meshes":[{"primitives":[)" + primitive + "]}]}";
}

}  // namespace

// fuzz_gltf: a primitive whose "attributes" key is misspelt is dropped by tinygltf but listed in
// the JSON; the reader indexed tinygltf's empty primitive list (UBSan: reference to null).
TEST(FuzzRegressions, GltfPrimitiveWithoutAttributes) {
  const std::string dir = texdefrag::testing::temp_dir();
  put(dir + "/ok.gltf", gltf_with_primitive(R"({"attributes":{"POSITION":0}})"));
  EXPECT_EQ(read_gltf(dir + "/ok.gltf").mesh.faces.size(), 1u);  // the file is otherwise valid
  put(dir + "/m.gltf", gltf_with_primitive(R"({"aptributes":{"POSITION":0}})"));
  const std::string e = error_of([&] { read_gltf(dir + "/m.gltf"); });
  EXPECT_EQ(e.rfind(dir + "/m.gltf: mesh 0 primitive 0: no \"attributes\"", 0), 0u) << e;
}

// A member of another JSON type than the reader reads was a nlohmann type_error naming no file.
TEST(FuzzRegressions, GltfMemberOfTheWrongTypeNamesTheFile) {
  const std::string dir = texdefrag::testing::temp_dir();
  put(dir + "/t.gltf", gltf_with_primitive(R"({"attributes":{"POSITION":0},"mode":"4"})"));
  const std::string e = error_of([&] { read_gltf(dir + "/t.gltf"); });
  EXPECT_EQ(e.rfind(dir + "/t.gltf: ", 0), 0u) << e;
}

// fuzz_tiles3d: a content "uri" that is not a string was a type_error naming no file.
TEST(FuzzRegressions, TilesetUriOfTheWrongTypeNamesTheFile) {
  const std::string dir = texdefrag::testing::temp_dir();
  put(dir + "/tileset.json", R"({"asset":{"version":"1.0"},"root":{"geometricError":0,"content":{"uri":5}}})");
  const std::string e = error_of([&] { read_tileset(dir + "/tileset.json"); });
  EXPECT_EQ(e.rfind(dir + "/tileset.json: tileset JSON: ", 0), 0u) << e;
}

// fuzz_tiles3d: check_tileset on a tileset without "root" read freed memory (ASan: const
// operator[] on a missing key). Hardened with it (same class of bug, by reading the code): a tile
// that is not an object, a tileset naming itself (recursed until the stack ran out), an
// unreadable content (a problem naming the tileset and tile).
TEST(FuzzRegressions, CheckTilesetOnMalformedTilesets) {
  const std::string dir = texdefrag::testing::temp_dir();
  put(dir + "/noroot.json", R"({"asset":{"version":"1.0"},"geometricError":0})");
  std::vector<std::string> p = check_tileset(dir + "/noroot.json");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0], dir + "/noroot.json: not a tileset (no \"root\" tile)");

  put(dir + "/c.glb", "");  // exists, but is no GLB
  put(dir + "/box.json",
      R"({"asset":{"version":"1.0"},"root":{"geometricError":0,"boundingVolume":{"box":[1,2,3]},"content":{"uri":"c.glb"}}})");
  p = check_tileset(dir + "/box.json");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].rfind(dir + "/box.json root: ", 0), 0u) << p[0];

  put(dir + "/self.json", R"({"asset":{"version":"1.0"},"root":{"geometricError":0,"content":{"uri":"self.json"}}})");
  p = check_tileset(dir + "/self.json");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_NE(p[0].find("a cycle"), std::string::npos) << p[0];

  put(dir + "/tile.json", R"({"asset":{"version":"1.0"},"root":{"geometricError":0,"children":[5]}})");
  p = check_tileset(dir + "/tile.json");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0], dir + "/tile.json root/0: the tile is not a JSON object");
}

// fuzz_osgb: osgDB sizes strings and arrays from the file; a file that is not OSGB at all is now
// refused before osgDB sees it.
TEST(FuzzRegressions, OsgbHeaderIsCheckedFirst) {
  const std::string dir = texdefrag::testing::temp_dir();
  put(dir + "/text.osgb", "not an osgb file at all");
  std::string e = error_of([&] { OsgbFormat().read(dir + "/text.osgb"); });
  EXPECT_EQ(e, dir + "/text.osgb: not a binary OSGB file (bad magic)");
  put(dir + "/short.osgb", "\xA1\x0E");
  e = error_of([&] { OsgbFormat().read(dir + "/short.osgb"); });
  EXPECT_EQ(e, dir + "/short.osgb: not a binary OSGB file (shorter than its header)");
}
