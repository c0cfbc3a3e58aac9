// make_osgb_pyramid: a small ContextCapture-style OSGB pyramid from OBJ levels (docs/production.md,
// "The bundled production"). Used to generate examples/production from examples/production_obj
// (tools/osgb_pyramid/make_example.sh) and by tests that need a PagedLOD pyramid.
//
//   make_osgb_pyramid OUT_DIR TILE LEVEL=FILE.obj [LEVEL=FILE.obj ...]   (coarsest level first)
//
// writes, for every level, OUT_DIR/Data/TILE/TILE_L<LEVEL>_0.osgb (a PagedLOD: that level's
// geometry inline, the next level's file as its file child; the last level is a plain leaf), and
// OUT_DIR/Data/TILE/TILE.osgb, the tile's root: a PagedLOD without geometry whose one file child is
// the coarsest level's file (ContextCapture roots usually hold a coarser level inline too; this one
// has no textured face, so texdefrag copies it unchanged). Ranges are in pixels on screen, as
// ContextCapture writes them. Each OBJ is read by OpenSceneGraph's own OBJ plugin; its JPEG/PNG
// pages are embedded as the files' bytes (WriteImageHint=IncludeFile), so the pyramid carries the
// input's JPEG streams unchanged. No optimiser runs: the geometry is the plugin's, as read.
// Exit 0 on success, 2 on a usage error or a file that cannot be read or written (named).
#include <osg/Geode>
#include <osg/PagedLOD>
#include <osg/ref_ptr>
#include <osgDB/Options>
#include <osgDB/ReadFile>
#include <osgDB/WriteFile>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

namespace fs = std::filesystem;

namespace {

/// Pixel size on screen above which the next (finer) level is shown.
constexpr float kSwitchPixels = 512.0f;

struct Level {
  int number = 0;
  fs::path obj;
};

int usage(const std::string& why) {
  std::cerr << "make_osgb_pyramid: " << why << "\n"
            << "usage: make_osgb_pyramid OUT_DIR TILE LEVEL=FILE.obj [LEVEL=FILE.obj ...]  (coarsest first)\n";
  return 2;
}

/// The geometry of one level, read by osgDB's OBJ plugin (textures keep their file names).
osg::ref_ptr<osg::Node> read_level(const Level& l) {
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("noRotation");
  osg::ref_ptr<osg::Node> n = osgDB::readRefNodeFile(l.obj.string(), opt.get());
  if (!n) throw std::runtime_error(l.obj.string() + ": OpenSceneGraph cannot read it (osgdb_obj plugin missing?)");
  return n;
}

/// The root: a PagedLOD with one file child, shown at every range, around `bound`.
osg::ref_ptr<osg::Node> root_node(const osg::BoundingSphere& bound, const std::string& child) {
  osg::ref_ptr<osg::PagedLOD> lod = new osg::PagedLOD;
  lod->setCenterMode(osg::LOD::USER_DEFINED_CENTER);
  lod->setCenter(bound.center());
  lod->setRadius(bound.radius());
  lod->setRangeMode(osg::LOD::PIXEL_SIZE_ON_SCREEN);
  lod->setFileName(0, child);
  lod->setRange(0, 0.0f, 1e30f);
  return lod;
}

/// A PagedLOD showing `geometry` up to kSwitchPixels and the file `child` beyond (none: a leaf).
osg::ref_ptr<osg::Node> level_node(const osg::ref_ptr<osg::Node>& geometry, const std::string& child) {
  if (child.empty()) return geometry;
  osg::ref_ptr<osg::PagedLOD> lod = new osg::PagedLOD;
  const osg::BoundingSphere bs = geometry->getBound();
  lod->setCenterMode(osg::LOD::USER_DEFINED_CENTER);
  lod->setCenter(bs.center());
  lod->setRadius(bs.radius());
  lod->setRangeMode(osg::LOD::PIXEL_SIZE_ON_SCREEN);
  lod->addChild(geometry.get(), 0.0f, kSwitchPixels);
  lod->setFileName(1, child);
  lod->setRange(1, kSwitchPixels, 1e30f);
  return lod;
}

void write(const osg::Node& node, const fs::path& path) {
  osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeFile");
  if (!osgDB::writeNodeFile(node, path.string(), opt.get()))
    throw std::runtime_error(path.string() + ": OpenSceneGraph could not write it (osgdb_osg plugin missing?)");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return usage("expected OUT_DIR, TILE and at least one LEVEL=FILE.obj");
  const fs::path out = argv[1];
  const std::string tile = argv[2];
  if (tile.empty() || tile.find('/') != std::string::npos) return usage("TILE must be a plain name (Tile_+000_+000)");
  std::vector<Level> levels;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    const size_t eq = a.find('=');
    char* end = nullptr;
    const long n = eq == std::string::npos ? 0 : std::strtol(a.substr(0, eq).c_str(), &end, 10);
    if (eq == std::string::npos || eq == 0 || *end != '\0' || n < 0 || n > 99)
      return usage("'" + a + "' is not LEVEL=FILE.obj with LEVEL in 0..99");
    levels.push_back({static_cast<int>(n), fs::path(a.substr(eq + 1))});
  }
  try {
    const fs::path dir = out / "Data" / tile;
    fs::create_directories(dir);
    auto file_of = [&](size_t k) { return tile + "_L" + std::to_string(levels[k].number) + "_0.osgb"; };
    osg::BoundingSphere coarsest;
    for (size_t k = 0; k < levels.size(); ++k) {
      const std::string child = k + 1 < levels.size() ? file_of(k + 1) : std::string();
      const osg::ref_ptr<osg::Node> geometry = read_level(levels[k]);
      if (k == 0) coarsest = geometry->getBound();
      write(*level_node(geometry, child), dir / file_of(k));
    }
    write(*root_node(coarsest, file_of(0)), dir / (tile + ".osgb"));
  } catch (const std::exception& e) {
    std::cerr << "make_osgb_pyramid: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
