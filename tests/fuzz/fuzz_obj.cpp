// libFuzzer target for the OBJ reader and the framework's mesh analysis (docs/io.md, "Fuzzing").
//
// Each input is written as an OBJ beside a fixed MTL (material `m`, map_Kd tex.png, a 16x16 PNG),
// so inputs can reference real materials and pages. Properties checked on every input:
// - read_obj either succeeds or throws ObjError (any other exception, crash, leak or undefined
//   behaviour is a finding: the target is built with AddressSanitizer and UBSan);
// - a mesh that reads back is analysed without error: topology, charts, chart statistics,
//   distortion;
// - write_obj then read_obj gives the same faces, positions (bit for bit), texture coordinates and
//   pages, or write_obj refuses with ObjError (meshes it cannot represent).
// Build: CXX=clang++ cmake -DTEXDEFRAG_FUZZ=ON ...; run: fuzz_obj tests/fuzz/corpus (see docs/io.md).
#include "texdefrag/core/charts.h"
#include "texdefrag/core/distortion.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_obj: %s\n", what);
  std::abort();
}

const fs::path& work_dir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("texdefrag-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(d / "out");
    std::ofstream(d / "fuzz.mtl") << "newmtl m\nmap_Kd tex.png\nnewmtl plain\nKd 1 1 1\n";
    Image img;
    img.width = img.height = 16;
    img.channels = 3;
    img.pixels.assign(16 * 16 * 3, 128);
    write_image((d / "tex.png").string(), img, ImageFormat::Png);
    return d;
  }();
  return dir;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path obj = work_dir() / "in.obj";
  {
    std::ofstream f(obj, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  TexturedMesh mesh;
  try {
    mesh = read_obj(obj.string());
  } catch (const ObjError&) {
    return 0;
  }
  const Topology topo = build_topology(mesh);
  const ChartSet charts = build_charts(mesh, topo);
  (void)chart_stats(mesh, topo, charts.atlas);
  (void)atlas_distortion(mesh, charts.atlas);

  const fs::path out = work_dir() / "out" / "in.obj";
  try {
    write_obj(mesh, out.string());
  } catch (const ObjError&) {
    return 0;
  }
  TexturedMesh back;
  try {
    ObjReadOptions ro;  // write_obj does not write images: the copy's map_Kd files are absent
    ro.read_page_sizes = false;
    ro.require_textures = false;
    back = read_obj(out.string(), ro);
  } catch (const ObjError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    finding("a written OBJ does not read back");
  }
  if (back.faces.size() != mesh.faces.size() || back.positions.size() != mesh.positions.size())
    finding("round trip changed the face or position count");
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!same_bits(mesh.positions[i][k], back.positions[i][k])) finding("round trip changed a position");
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (mesh.faces[f].page != back.faces[f].page) finding("round trip changed a face's page");
    for (int k = 0; k < 3; ++k) {
      if (mesh.faces[f].v[static_cast<size_t>(k)] != back.faces[f].v[static_cast<size_t>(k)])
        finding("round trip changed a face's vertices");
      const int ta = mesh.faces[f].vt[static_cast<size_t>(k)], tb = back.faces[f].vt[static_cast<size_t>(k)];
      if ((ta < 0) != (tb < 0)) finding("round trip changed whether a corner has a texture coordinate");
      if (ta >= 0)
        for (int c = 0; c < 2; ++c)
          if (!same_bits(mesh.texcoords[static_cast<size_t>(ta)][c], back.texcoords[static_cast<size_t>(tb)][c]))
            finding("round trip changed a texture coordinate");
    }
  }
  return 0;
}
