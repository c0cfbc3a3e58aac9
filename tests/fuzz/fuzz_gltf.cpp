// libFuzzer target for the glTF 2.0 / GLB reader (framework/src/io/gltf_read.cpp, gltf_draco.cpp:
// tinygltf, Draco-compressed primitives; docs/io.md "Fuzzing").
//
// Each input is one document given as bytes (GltfInput::bytes, as a b3dm's GLB is), named in.glb
// when it starts with the GLB magic and in.gltf otherwise, in a folder that also holds tex.png (a
// 4x4 PNG an external image URI can name). Properties checked on every input:
// - read_gltf (page sizes read, embedded pages decoded) either succeeds or throws GltfError or
//   ImageError whose message starts with the input's folder (it names the document, or an image
//   file the document names); any other exception, a crash, a leak, a hang or undefined behaviour
//   is a finding (ASan + UBSan build);
// - a model that reads has one face source per face, one page source per page, and its mesh passes
//   fuzz::analyse (indices in range, topology, charts, distortion).
// Seeds: make_fuzz_seeds (GLB, .gltf JSON, strips, fans, Draco sequential and Edgebreaker).
#include "fuzz_model.h"

#include "texdefrag/io/gltf.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

using namespace texdefrag;

namespace {

const char* const kTarget = "fuzz_gltf";

const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path d = fuzz::work_dir(kTarget);
    Image img;
    img.width = img.height = 4;
    img.channels = 3;
    img.pixels.assign(4 * 4 * 3, 200);
    write_image((d / "tex.png").string(), img, ImageFormat::Png);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;  // empty bytes mean "read the file" to read_gltf
  GltfInput in;
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  in.path = (folder() / (glb ? "in.glb" : "in.gltf")).string();
  in.bytes.assign(data, data + size);
  GltfModel m;
  try {
    m = read_gltf(std::vector<GltfInput>{in});
  } catch (const GltfError& e) {
    fuzz::expect_named(kTarget, e.what(), folder().string());
    return 0;
  } catch (const ImageError& e) {
    fuzz::expect_named(kTarget, e.what(), folder().string());
    return 0;
  }
  if (m.face_source.size() != m.mesh.faces.size()) fuzz::finding(kTarget, "face sources and faces differ in number");
  if (m.page_source.size() != m.mesh.pages.size()) fuzz::finding(kTarget, "page sources and pages differ in number");
  fuzz::analyse(kTarget, m.mesh);
  return 0;
}
