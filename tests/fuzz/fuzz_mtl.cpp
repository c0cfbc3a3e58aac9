// libFuzzer target for the MTL reader (docs/io.md, "Fuzzing").
//
// Each input is written as fuzz.mtl beside a fixed OBJ (two textured triangles under `usemtl m`, one
// under `usemtl plain`) and a 16x16 PNG tex.png, so inputs may name real and missing images.
// Properties checked on every input:
// - read_obj either succeeds or throws ObjError/ImageError (anything else, a crash, a leak or
//   undefined behaviour is a finding: the target is built with AddressSanitizer and UBSan);
// - a model that reads has every page's size known and every face's page consistent with its
//   material, and write_obj then read_obj keeps its faces' pages and materials' extra lines, or
//   write_obj refuses with ObjError.
// Build: CXX=clang++ cmake -DTEXDEFRAG_FUZZ=ON ...; run: fuzz_mtl tests/fuzz/corpus_mtl.
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_mtl: %s\n", what);
  std::abort();
}

const fs::path& work_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("texdefrag-fuzz-mtl-" + std::to_string(::getpid()));
    fs::create_directories(d / "out");
    std::ofstream(d / "in.obj") << "mtllib fuzz.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                   "usemtl m\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\nusemtl plain\nf 1 2 4\n";
    Image img;
    img.width = img.height = 16;
    img.channels = 3;
    img.pixels.assign(16 * 16 * 3, 128);
    write_image((d / "tex.png").string(), img, ImageFormat::Png);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  {
    std::ofstream f(work_dir() / "fuzz.mtl", std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  TexturedMesh mesh;
  try {
    mesh = read_obj((work_dir() / "in.obj").string());
  } catch (const ObjError&) {
    return 0;
  } catch (const ImageError&) {
    return 0;
  }
  for (const Page& p : mesh.pages)
    if (p.width <= 0 || p.height <= 0) finding("a page read without its size");
  for (const Face& f : mesh.faces)
    if (f.page != kNoPage && (f.page >= static_cast<int>(mesh.pages.size()) || f.material == kNoIndex ||
                              mesh.pages[static_cast<size_t>(f.page)].material !=
                                  mesh.materials[static_cast<size_t>(f.material)].name))
      finding("a face's page is not its material's");
  const fs::path out = work_dir() / "out" / "in.obj";
  try {
    write_obj(mesh, out.string());
  } catch (const ObjError&) {
    return 0;
  }
  TexturedMesh back;
  try {
    ObjReadOptions ro;  // write_obj does not write images
    ro.read_page_sizes = false;
    ro.require_textures = false;
    back = read_obj(out.string(), ro);
  } catch (const ObjError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    finding("a written MTL does not read back");
  }
  if (back.faces.size() != mesh.faces.size() || back.pages.size() != mesh.pages.size())
    finding("round trip changed the face or page count");
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    if (back.faces[f].page != mesh.faces[f].page) finding("round trip changed a face's page");
  for (size_t m = 0; m < mesh.materials.size() && m < back.materials.size(); ++m)
    if (back.materials[m].name == mesh.materials[m].name && back.materials[m].extra_lines != mesh.materials[m].extra_lines)
      finding("round trip changed a material's lines");
  return 0;
}
