// libFuzzer target for the OSGB reader (framework/src/io/osgb_read.cpp over OpenSceneGraph's osgb
// plugin; docs/io.md "Fuzzing").
//
// Each input is written as in.osgb beside triangles.osgb (a valid tile a PagedLOD can name).
// Properties checked on every input:
// - OsgbFormat::read and osgb_children either succeed or throw FormatError whose message starts
//   with the input's path; any other exception, a crash, a leak, a hang or undefined behaviour is
//   a finding (ASan + UBSan build). osgDB reads each input first in the bounded child process
//   (docs/io.md "OSGB: bounded reading"): its allocations of gigabytes, loops and crashes end that
//   child and are errors naming the file; OpenSceneGraph is not instrumented, so its own memory
//   errors show only when they crash;
// - a model that reads has one page image and one page encoding per page, each image of the page's
//   size, and its mesh passes fuzz::analyse (indices in range, topology, charts, distortion).
// Seeds: make_fuzz_seeds (triangles, strips, fans with DrawArrayLengths, Vec3dArray, a PagedLOD
// with an inline and a file child, embedded images).
#include "fuzz_model.h"

#include "texdefrag/io/osgb.h"

#include <osg/Notify>

#include <cstdint>
#include <fstream>
#include <string>

using namespace texdefrag;

namespace {

const char* const kTarget = "fuzz_osgb";

const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    osg::setNotifyLevel(osg::FATAL);  // the plugin's warnings on every malformed input
    // note: inputs are at most a few KB and the seeds need ~20 MiB: tighter limits than a real
    // file's (512 MiB, 3 s) keep the executions on hostile inputs short; the limit paths are the same.
    OsgbReadLimits limits;
    limits.memory_bytes = 128ull << 20;
    limits.cpu_seconds = 1;
    limits.wall_seconds = 15;
    set_osgb_read_limits(limits);
    const std::filesystem::path d = fuzz::work_dir(kTarget);
    std::filesystem::copy_file(std::string(TEXDEFRAG_FUZZ_SEEDS) + "/osgb/triangles.osgb", d / "triangles.osgb",
                               std::filesystem::copy_options::overwrite_existing);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = (folder() / "in.osgb").string();
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  LoadedModel m;
  try {
    m = OsgbFormat().read(path);
    (void)osgb_children(path);
  } catch (const FormatError& e) {
    fuzz::expect_named(kTarget, e.what(), path);
    return 0;
  }
  if (m.page_images.size() != m.mesh.pages.size() || m.page_encodings.size() != m.mesh.pages.size())
    fuzz::finding(kTarget, "page images or encodings and pages differ in number");
  for (size_t p = 0; p < m.page_images.size(); ++p) {
    const Image& im = m.page_images[p];
    if (im.width != m.mesh.pages[p].width || im.height != m.mesh.pages[p].height ||
        im.pixels.size() != static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * static_cast<size_t>(im.channels))
      fuzz::finding(kTarget, "a page image does not match its page's size");
  }
  fuzz::analyse(kTarget, m.mesh);
  return 0;
}
