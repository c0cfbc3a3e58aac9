// Helpers shared by the OSGB tests: a structure dump that two scene graphs must share, and the
// face-by-face position comparison of two reads.
#pragma once

#include "texdefrag/io/model_format.h"

#include <osg/Geode>
#include <osg/Geometry>
#include <osg/MatrixTransform>
#include <osg/NodeVisitor>
#include <osg/PagedLOD>
#include <osg/Texture>
#include <osgDB/ReadFile>

#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>
#include <string>

namespace texdefrag::osgb_test {

inline std::string exact(double d) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", d);
  return buf;
}

/// Node classes, names, PagedLOD centres/radii/ranges/child names/priorities, transforms,
/// StateSet attribute types and modes, drawables per Geode, texture parameters: everything the
/// writer must keep (not vertex counts or primitive sets, which a vertex split may change).
class StructureDump : public osg::NodeVisitor {
 public:
  StructureDump() : osg::NodeVisitor(TRAVERSE_ALL_CHILDREN) {}
  std::ostringstream out;
  void apply(osg::Node& n) override {
    head(n);
    indent_ += 1;
    traverse(n);
    indent_ -= 1;
  }
  void apply(osg::PagedLOD& n) override {
    head(n);
    out << pad() << " centre " << exact(n.getCenter().x()) << " " << exact(n.getCenter().y()) << " "
        << exact(n.getCenter().z()) << " radius " << exact(n.getRadius()) << " mode " << n.getCenterMode()
        << " rangemode " << n.getRangeMode() << "\n";
    for (unsigned i = 0; i < n.getNumRanges(); ++i)
      out << pad() << " range " << exact(n.getMinRange(i)) << " " << exact(n.getMaxRange(i)) << "\n";
    for (unsigned i = 0; i < n.getNumFileNames(); ++i)
      out << pad() << " file '" << n.getFileName(i) << "' priority " << exact(n.getPriorityOffset(i)) << " "
          << exact(n.getPriorityScale(i)) << "\n";
    indent_ += 1;
    traverse(n);
    indent_ -= 1;
  }
  void apply(osg::MatrixTransform& n) override {
    head(n);
    for (int i = 0; i < 16; ++i) out << " " << exact(n.getMatrix().ptr()[i]);
    out << "\n";
    indent_ += 1;
    traverse(n);
    indent_ -= 1;
  }
  void apply(osg::Drawable& d) override {
    head(d);
    if (osg::Geometry* g = d.asGeometry())
      out << pad() << " vertices " << (g->getVertexArray() ? g->getVertexArray()->className() : "none")
          << " texcoords0 " << (g->getTexCoordArray(0) ? g->getTexCoordArray(0)->className() : "none") << "\n";
  }

 private:
  std::string pad() const { return std::string(static_cast<size_t>(indent_) * 2, ' '); }
  void head(osg::Object& o) {
    out << pad() << o.className() << " '" << o.getName() << "'\n";
    const osg::StateSet* ss = nullptr;
    if (auto* n = dynamic_cast<osg::Node*>(&o)) ss = n->getStateSet();
    if (!ss) return;
    for (const auto& a : ss->getAttributeList()) out << pad() << " attr " << a.second.first->className() << "\n";
    for (const auto& m : ss->getModeList()) out << pad() << " mode " << m.first << " " << m.second << "\n";
    for (size_t u = 0; u < ss->getTextureAttributeList().size(); ++u)
      for (const auto& a : ss->getTextureAttributeList()[u]) {
        out << pad() << " tex" << u << " " << a.second.first->className();
        if (auto* t = dynamic_cast<const osg::Texture*>(a.second.first.get()))
          out << " wrap " << t->getWrap(osg::Texture::WRAP_S) << " " << t->getWrap(osg::Texture::WRAP_T) << " filter "
              << t->getFilter(osg::Texture::MIN_FILTER) << " " << t->getFilter(osg::Texture::MAG_FILTER)
              << (t->getImage(0) ? " image" : " no-image");
        out << "\n";
      }
  }
  int indent_ = 0;
};

inline std::string structure(const std::string& path) {
  osg::ref_ptr<osg::Node> n = osgDB::readRefNodeFile(path);
  if (!n) return "unreadable " + path;
  StructureDump d;
  n->accept(d);
  return d.out.str();
}

/// Expects the same faces with bit-identical corner positions, in the same order.
inline void expect_same_positions(const TexturedMesh& a, const TexturedMesh& b, const std::string& what) {
  ASSERT_EQ(a.faces.size(), b.faces.size()) << what;
  size_t differ = 0;
  for (size_t f = 0; f < a.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = a.corner_position(f, k);
      const Vec3& q = b.corner_position(f, k);
      differ += !(p.x() == q.x() && p.y() == q.y() && p.z() == q.z() && std::signbit(p.x()) == std::signbit(q.x()));
    }
  EXPECT_EQ(differ, 0u) << what << ": corners whose position changed";
}

}  // namespace texdefrag::osgb_test
