// libFuzzer target for the 3D Tiles reader (framework/src/io/tiles3d.cpp, tiles3d_check.cpp):
// tileset JSON and the b3dm container (docs/io.md "Fuzzing").
//
// An input starting with "b3dm" is a b3dm: parse_b3dm, then its GLB through read_gltf (as a
// tileset run reads it); a b3dm that parses is written back with write_b3dm and must parse to the
// same tables and GLB (plus zero padding to 8 bytes). Any other input is written as
// t/tileset.json in a folder holding a.b3dm, b.glb and sub/ext.json (an external tileset naming
// sub/c.glb), and goes through is_tileset, plan_tileset (with and without keep_going) and
// check_tileset. Properties checked on every input:
// - each call either succeeds or throws TilesetError, GltfError or ImageError whose message starts
//   with the input's folder (it names the tileset, b3dm or content); any other exception, a crash,
//   a leak, a hang or undefined behaviour is a finding (ASan + UBSan build);
// - a plan puts every glTF/GLB/b3dm content of the tileset in exactly one model.
// Seeds: make_fuzz_seeds (a tileset naming a b3dm, a GLB and an external tileset; a 1.1 tileset
// with a region; a b3dm with feature and batch tables).
#include "fuzz_model.h"

#include "texdefrag/io/gltf.h"
#include "texdefrag/io/tiles3d.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

const char* const kTarget = "fuzz_tiles3d";

const fs::path& folder() {
  static const fs::path dir = [] {
    const fs::path d = fuzz::work_dir(kTarget);
    const std::string seeds = TEXDEFRAG_FUZZ_SEEDS;
    fs::create_directories(d / "t" / "sub");
    const auto copy = fs::copy_options::overwrite_existing;
    fs::copy_file(seeds + "/tiles3d/a.b3dm", d / "t" / "a.b3dm", copy);
    fs::copy_file(seeds + "/gltf/grid.glb", d / "t" / "b.glb", copy);
    fs::copy_file(seeds + "/gltf/draco_sequential.glb", d / "t" / "sub" / "c.glb", copy);
    std::ofstream(d / "t" / "sub" / "ext.json")
        << R"({"asset":{"version":"1.0"},"geometricError":1,"root":{"geometricError":0,)"
        << R"("boundingVolume":{"sphere":[0,0,0,10]},"content":{"uri":"c.glb"}}})";
    return d;
  }();
  return dir;
}

template <class Fn>
bool named_error_or_ok(const Fn& fn) {
  try {
    fn();
    return true;
  } catch (const TilesetError& e) {
    fuzz::expect_named(kTarget, e.what(), folder().string());
  } catch (const GltfError& e) {
    fuzz::expect_named(kTarget, e.what(), folder().string());
  } catch (const ImageError& e) {
    fuzz::expect_named(kTarget, e.what(), folder().string());
  }
  return false;
}

void b3dm_input(const uint8_t* data, size_t size) {
  const std::string path = (folder() / "in.b3dm").string();
  const std::vector<uint8_t> bytes(data, data + size);
  B3dm b;
  if (!named_error_or_ok([&] { b = parse_b3dm(bytes, path); })) return;
  const std::string again = write_b3dm(b);
  B3dm c;
  if (!named_error_or_ok([&] { c = parse_b3dm(std::vector<uint8_t>(again.begin(), again.end()), path); }))
    fuzz::finding(kTarget, "a b3dm written by write_b3dm does not parse");
  if (c.feature_table_json != b.feature_table_json || c.feature_table_binary != b.feature_table_binary ||
      c.batch_table_json != b.batch_table_json || c.batch_table_binary != b.batch_table_binary)
    fuzz::finding(kTarget, "write_b3dm then parse_b3dm changed a table");
  // write_b3dm pads the GLB to 8 bytes; parse_b3dm cuts a GLB to its own length, other payloads
  // (not a GLB: read_gltf refuses them) keep the zero padding.
  const bool padded = c.glb.size() >= b.glb.size() && c.glb.size() < b.glb.size() + 8 &&
                      std::equal(b.glb.begin(), b.glb.end(), c.glb.begin()) &&
                      std::all_of(c.glb.begin() + static_cast<std::ptrdiff_t>(b.glb.size()), c.glb.end(), [](uint8_t v) { return v == 0; });
  if (!padded) fuzz::finding(kTarget, "write_b3dm then parse_b3dm changed the GLB");
  if (b.glb.empty()) return;  // empty bytes mean "read the file" to read_gltf
  GltfModel m;
  if (named_error_or_ok([&] { m = read_gltf(std::vector<GltfInput>{{path, b.glb, folder().string()}}); }))
    fuzz::analyse(kTarget, m.mesh);
}

void tileset_input(const uint8_t* data, size_t size) {
  const std::string path = (folder() / "t" / "tileset.json").string();
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  (void)is_tileset(path);
  for (bool keep_going : {false, true}) {
    TilesetPlan plan;
    if (!named_error_or_ok([&] { plan = plan_tileset(path, keep_going); })) continue;
    size_t models_contents = 0, gltf_contents = 0;
    for (const TilesetModel& model : plan.models) models_contents += model.contents.size();
    for (const TilesetContent& c : plan.tileset.contents) gltf_contents += c.kind == "glb" || c.kind == "gltf" || c.kind == "b3dm";
    if (models_contents != gltf_contents) fuzz::finding(kTarget, "a plan's models do not hold every glTF/b3dm content once");
  }
  (void)named_error_or_ok([&] { (void)check_tileset(path); });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size >= 4 && std::memcmp(data, "b3dm", 4) == 0) b3dm_input(data, size);
  else tileset_input(data, size);
  return 0;
}
