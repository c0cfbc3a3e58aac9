// OSGB writer (see texdefrag/io/osgb.h and docs/io.md "OSGB").
#include "osgb_source.h"
#include "texdefrag/io/osgb.h"

#include <osg/Geode>
#include <osg/NodeVisitor>
#include <osg/PagedLOD>
#include <osg/ProxyNode>
#include <osg/StateSet>
#include <osgDB/FileNameUtils>
#include <osgDB/Registry>
#include <osgDB/WriteFile>

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <unordered_map>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

using osgb_detail::FaceRecord;
using osgb_detail::GeometryRecord;
using osgb_detail::OsgbSource;

/// What a corner needs: its output page and texture coordinate (as the float stored).
struct CornerKey {
  int page = kNoPage;
  double u = 0, v = 0;
  bool operator==(const CornerKey& o) const { return page == o.page && u == o.u && v == o.v; }
};

struct WriteCounts {
  size_t vertices_added = 0;
  size_t primitive_sets_reindexed = 0;   ///< same mode, new indices
  size_t primitive_sets_triangulated = 0;  ///< rewritten as DrawElementsUInt triangles
  size_t geometries_split = 0;           ///< geometries whose faces span several output pages
  size_t geometries_added = 0;
  size_t statesets_added = 0;
};

/// A copy of a per-vertex array with the elements `sources` appended (bit-identical copies).
osg::ref_ptr<osg::Array> extended(const osg::Array* a, const std::vector<uint32_t>& sources) {
  osg::ref_ptr<osg::Array> b = osg::clone(a, osg::CopyOp::DEEP_COPY_ALL);
  if (sources.empty()) return b;
  const unsigned n = a->getNumElements();
  const size_t es = a->getElementSize();
  b->resizeArray(n + static_cast<unsigned>(sources.size()));
  auto* base = static_cast<uint8_t*>(const_cast<GLvoid*>(b->getDataPointer()));
  for (size_t i = 0; i < sources.size(); ++i) std::memcpy(base + (n + i) * es, base + sources[i] * es, es);
  return b;
}

bool per_vertex(const osg::Array* a, unsigned vertices) {
  return a && a->getNumElements() == vertices &&
         (a->getBinding() == osg::Array::BIND_PER_VERTEX || a->getBinding() == osg::Array::BIND_UNDEFINED);
}

/// Appends copies of vertices `sources` to every per-vertex array of g.
void extend_vertex_arrays(const std::string& path, osg::Geometry& g, const std::vector<uint32_t>& sources) {
  if (sources.empty()) return;
  const unsigned n = g.getVertexArray()->getNumElements();
  g.setVertexArray(extended(g.getVertexArray(), sources).get());
  auto check = [&](const osg::Array* a, const char* what) {
    if (a && a->getBinding() == osg::Array::BIND_PER_VERTEX && a->getNumElements() != n)
      throw FormatError(path + ": a geometry's " + what + " array has " + std::to_string(a->getNumElements()) +
                        " elements for " + std::to_string(n) + " vertices");
    return per_vertex(a, n) && a->getBinding() == osg::Array::BIND_PER_VERTEX;
  };
  if (check(g.getNormalArray(), "normal")) g.setNormalArray(extended(g.getNormalArray(), sources).get());
  if (check(g.getColorArray(), "colour")) g.setColorArray(extended(g.getColorArray(), sources).get());
  if (check(g.getSecondaryColorArray(), "secondary colour"))
    g.setSecondaryColorArray(extended(g.getSecondaryColorArray(), sources).get());
  if (check(g.getFogCoordArray(), "fog coordinate")) g.setFogCoordArray(extended(g.getFogCoordArray(), sources).get());
  for (unsigned u = 0; u < g.getNumTexCoordArrays(); ++u)
    if (per_vertex(g.getTexCoordArray(u), n)) g.setTexCoordArray(u, extended(g.getTexCoordArray(u), sources).get());
  for (unsigned i = 0; i < g.getNumVertexAttribArrays(); ++i)
    if (check(g.getVertexAttribArray(i), "vertex attribute"))
      g.setVertexAttribArray(i, extended(g.getVertexAttribArray(i), sources).get());
}

/// Output vertex of every corner of a geometry's faces; vertices split where corners disagree.
struct CornerPlan {
  std::vector<uint32_t> target;       ///< 3 per face of the geometry
  std::vector<uint32_t> sources;      ///< appended vertex -> the vertex it copies
  std::vector<CornerKey> vertex_key;  ///< per output vertex; page kNoPage = no corner uses it
};

CornerPlan plan_corners(const GeometryRecord& rec, const std::vector<FaceRecord>& faces, const TexturedMesh& out) {
  const osg::Geometry& g = *rec.geometry;
  const uint32_t n = g.getVertexArray()->getNumElements();
  CornerPlan plan;
  plan.vertex_key.resize(n);
  plan.target.resize(rec.num_faces * 3);
  std::unordered_map<uint32_t, std::vector<uint32_t>> copies;  // vertex -> its appended copies
  for (size_t i = 0; i < rec.num_faces; ++i) {
    const size_t f = rec.first_face + i;
    const FaceRecord& fr = faces[f];
    const Face& F = out.faces[f];
    const osg::PrimitiveSet& ps = *g.getPrimitiveSet(fr.primitive_set);
    for (size_t k = 0; k < 3; ++k) {
      const Vec2& t = out.texcoords[static_cast<size_t>(F.vt[k])];
      const CornerKey key{F.page, static_cast<float>(t.x()), static_cast<float>(t.y())};
      const uint32_t vi = ps.index(fr.occurrence[k]);
      uint32_t target = vi;
      if (plan.vertex_key[vi].page == kNoPage) {
        plan.vertex_key[vi] = key;
      } else if (!(plan.vertex_key[vi] == key)) {
        target = UINT32_MAX;
        for (uint32_t c : copies[vi])
          if (plan.vertex_key[c] == key) target = c;
        if (target == UINT32_MAX) {
          target = n + static_cast<uint32_t>(plan.sources.size());
          plan.sources.push_back(vi);
          plan.vertex_key.push_back(key);
          copies[vi].push_back(target);
        }
      }
      plan.target[i * 3 + k] = target;
    }
  }
  return plan;
}

/// Writes the new unit-0 texture coordinates (same array type as the input's).
void set_texcoords(osg::Geometry& g, const CornerPlan& plan) {
  const osg::Array* old = g.getTexCoordArray(0);
  osg::ref_ptr<osg::Array> tc = osg::clone(old, osg::CopyOp::DEEP_COPY_ALL);
  if (auto* f = dynamic_cast<osg::Vec2Array*>(tc.get())) {
    for (size_t i = 0; i < plan.vertex_key.size(); ++i)
      if (plan.vertex_key[i].page != kNoPage)
        (*f)[i].set(static_cast<float>(plan.vertex_key[i].u), static_cast<float>(plan.vertex_key[i].v));
  } else if (auto* d = dynamic_cast<osg::Vec2dArray*>(tc.get())) {
    for (size_t i = 0; i < plan.vertex_key.size(); ++i)
      if (plan.vertex_key[i].page != kNoPage) (*d)[i].set(plan.vertex_key[i].u, plan.vertex_key[i].v);
  }
  g.setTexCoordArray(0, tc.get());
}

/// Triangles (output vertex indices) of faces [begin, end) of the geometry's plan.
osg::ref_ptr<osg::DrawElementsUInt> triangles_of(const CornerPlan& plan, const std::vector<size_t>& local_faces) {
  osg::ref_ptr<osg::DrawElementsUInt> d = new osg::DrawElementsUInt(GL_TRIANGLES);
  d->reserve(local_faces.size() * 3);
  for (size_t i : local_faces)
    for (size_t k = 0; k < 3; ++k) d->push_back(plan.target[i * 3 + k]);
  return d;
}

/// A primitive set with the same mode and indices `idx` (its own element type when they fit).
osg::ref_ptr<osg::PrimitiveSet> reindexed(const osg::PrimitiveSet& ps, const std::vector<uint32_t>& idx) {
  uint32_t top = 0;
  for (uint32_t i : idx) top = std::max(top, i);
  if (ps.getType() == osg::PrimitiveSet::DrawElementsUShortPrimitiveType && top <= 0xFFFF) {
    osg::ref_ptr<osg::DrawElementsUShort> d = new osg::DrawElementsUShort(*static_cast<const osg::DrawElementsUShort*>(&ps), osg::CopyOp::DEEP_COPY_ALL);
    for (size_t i = 0; i < idx.size(); ++i) (*d)[i] = static_cast<GLushort>(idx[i]);
    return d;
  }
  if (ps.getType() == osg::PrimitiveSet::DrawElementsUBytePrimitiveType && top <= 0xFF) {
    osg::ref_ptr<osg::DrawElementsUByte> d = new osg::DrawElementsUByte(*static_cast<const osg::DrawElementsUByte*>(&ps), osg::CopyOp::DEEP_COPY_ALL);
    for (size_t i = 0; i < idx.size(); ++i) (*d)[i] = static_cast<GLubyte>(idx[i]);
    return d;
  }
  osg::ref_ptr<osg::DrawElementsUInt> d = new osg::DrawElementsUInt(ps.getMode(), idx.begin(), idx.end());
  d->setName(ps.getName());
  return d;
}

/// Rewrites the geometry's primitive sets where corners moved to copied vertices. Single-page
/// geometries only (all faces on one output page).
void rewrite_primitive_sets(const GeometryRecord& rec, const std::vector<FaceRecord>& faces, const CornerPlan& plan,
                            WriteCounts& counts) {
  osg::Geometry& g = *rec.geometry;
  std::vector<std::vector<int64_t>> occ(g.getNumPrimitiveSets());
  std::vector<std::vector<size_t>> set_faces(g.getNumPrimitiveSets());
  std::vector<uint8_t> conflict(g.getNumPrimitiveSets(), 0), changed(g.getNumPrimitiveSets(), 0);
  for (size_t i = 0; i < rec.num_faces; ++i) {
    const FaceRecord& fr = faces[rec.first_face + i];
    const osg::PrimitiveSet& ps = *g.getPrimitiveSet(fr.primitive_set);
    auto& o = occ[fr.primitive_set];
    if (o.empty()) o.assign(ps.getNumIndices(), -1);
    set_faces[fr.primitive_set].push_back(i);
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t t = plan.target[i * 3 + k];
      int64_t& slot = o[fr.occurrence[k]];
      if (slot >= 0 && slot != t) conflict[fr.primitive_set] = 1;
      slot = t;
      if (t != ps.index(fr.occurrence[k])) changed[fr.primitive_set] = 1;
    }
  }
  for (unsigned s = 0; s < g.getNumPrimitiveSets(); ++s) {
    if (!changed[s]) continue;
    const osg::PrimitiveSet& ps = *g.getPrimitiveSet(s);
    const bool lengths = ps.getType() == osg::PrimitiveSet::DrawArrayLengthsPrimitiveType;
    if (conflict[s] || lengths) {
      g.setPrimitiveSet(s, triangles_of(plan, set_faces[s]).get());
      ++counts.primitive_sets_triangulated;
      continue;
    }
    std::vector<uint32_t> idx(ps.getNumIndices());
    for (uint32_t i = 0; i < idx.size(); ++i) idx[i] = occ[s][i] >= 0 ? static_cast<uint32_t>(occ[s][i]) : ps.index(i);
    g.setPrimitiveSet(s, reindexed(ps, idx).get());
    ++counts.primitive_sets_reindexed;
  }
}

/// Hands out the StateSet a geometry needs for output page `page`: the texture in force gets the
/// page's image the first time; a geometry needing another page than its texture already shows
/// gets its own StateSet copy with a copy of the texture.
class TextureAssigner {
 public:
  explicit TextureAssigner(const std::vector<osg::ref_ptr<osg::Image>>& images) : images_(images) {}
  void assign(osg::Geometry& g, osg::Texture* texture, int page, WriteCounts& counts) {
    const auto it = page_of_.find(texture);
    if (it == page_of_.end()) {
      texture->setImage(0, images_[static_cast<size_t>(page)].get());
      page_of_.emplace(texture, page);
      return;
    }
    if (it->second == page) return;
    osg::ref_ptr<osg::Texture>& copy = copies_[{texture, page}];
    if (!copy) {
      copy = osg::clone(texture, osg::CopyOp::SHALLOW_COPY);
      copy->setImage(0, images_[static_cast<size_t>(page)].get());
    }
    osg::ref_ptr<osg::StateSet> ss =
        g.getStateSet() ? new osg::StateSet(*g.getStateSet(), osg::CopyOp::SHALLOW_COPY) : new osg::StateSet;
    ss->setTextureAttribute(0, copy.get());
    g.setStateSet(ss.get());
    ++counts.statesets_added;
  }

 private:
  const std::vector<osg::ref_ptr<osg::Image>>& images_;
  std::map<const osg::Texture*, int> page_of_;
  std::map<std::pair<const osg::Texture*, int>, osg::ref_ptr<osg::Texture>> copies_;
};

/// Updates one textured geometry: vertex copies, texture coordinates, primitive sets, and (for
/// faces on several pages) sibling geometries; assigns textures.
void update_geometry(const std::string& path, const GeometryRecord& rec, const std::vector<FaceRecord>& faces,
                     const TexturedMesh& out, TextureAssigner& textures, WriteCounts& counts) {
  osg::Geometry& g = *rec.geometry;
  const CornerPlan plan = plan_corners(rec, faces, out);
  extend_vertex_arrays(path, g, plan.sources);
  set_texcoords(g, plan);
  counts.vertices_added += plan.sources.size();
  std::vector<int> pages;  // in order of first use
  std::map<int, std::vector<size_t>> faces_on;
  for (size_t i = 0; i < rec.num_faces; ++i) {
    const int p = out.faces[rec.first_face + i].page;
    if (!faces_on.count(p)) pages.push_back(p);
    faces_on[p].push_back(i);
  }
  if (pages.size() <= 1) {
    rewrite_primitive_sets(rec, faces, plan, counts);
    if (!pages.empty()) textures.assign(g, rec.texture.get(), pages[0], counts);
    return;
  }
  ++counts.geometries_split;
  const osg::ref_ptr<osg::Geometry> model = new osg::Geometry(g, osg::CopyOp::SHALLOW_COPY);
  g.removePrimitiveSet(0, g.getNumPrimitiveSets());
  g.addPrimitiveSet(triangles_of(plan, faces_on[pages[0]]).get());
  textures.assign(g, rec.texture.get(), pages[0], counts);
  for (size_t k = 1; k < pages.size(); ++k) {
    osg::ref_ptr<osg::Geometry> sibling = new osg::Geometry(*model, osg::CopyOp::SHALLOW_COPY);
    sibling->removePrimitiveSet(0, sibling->getNumPrimitiveSets());
    sibling->addPrimitiveSet(triangles_of(plan, faces_on[pages[k]]).get());
    textures.assign(*sibling, rec.texture.get(), pages[k], counts);
    for (osg::Group* parent : g.getParents()) parent->addChild(sibling.get());
    ++counts.geometries_added;
  }
}

/// osgDB stores, on reading, the file's folder as the database path of PagedLODs (and
/// ProxyNodes) that had none; clearing it again keeps the written file's children relative.
class ClearReadFolder : public osg::NodeVisitor {
 public:
  explicit ClearReadFolder(std::string folder)
      : osg::NodeVisitor(TRAVERSE_ALL_CHILDREN), folder_(std::move(folder)) {}
  void apply(osg::PagedLOD& n) override {
    if (same(n.getDatabasePath())) n.setDatabasePath("");
    traverse(n);
  }
  void apply(osg::ProxyNode& n) override {
    if (same(n.getDatabasePath())) n.setDatabasePath("");
    traverse(n);
  }

 private:
  bool same(const std::string& p) const {
    if (p.empty()) return false;
    return fs::path(p).lexically_normal() / "" == fs::path(folder_).lexically_normal() / "";
  }
  std::string folder_;
};

/// A temporary folder removed on destruction.
struct ScratchDir {
  std::string path;
  ScratchDir() {
    static std::atomic<int> counter{0};
    path = (fs::temp_directory_path() /
            ("texdefrag-osgb-" + std::to_string(::getpid()) + "-" + std::to_string(counter++)))
               .string();
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

/// An osg::Image of page `img` (memory row 0 = bottom) named `file_name`.
osg::ref_ptr<osg::Image> osg_image(const Image& img, const std::string& file_name) {
  static const GLenum kFormats[] = {0, GL_LUMINANCE, GL_LUMINANCE_ALPHA, GL_RGB, GL_RGBA};
  const GLenum fmt = kFormats[img.channels];
  osg::ref_ptr<osg::Image> im = new osg::Image;
  im->allocateImage(img.width, img.height, 1, fmt, GL_UNSIGNED_BYTE);
  const size_t row = static_cast<size_t>(img.width) * static_cast<size_t>(img.channels);
  for (int y = 0; y < img.height; ++y)
    std::memcpy(im->data(0, img.height - 1 - y), img.pixels.data() + row * static_cast<size_t>(y), row);
  im->setInternalTextureFormat(static_cast<GLint>(fmt));
  im->setFileName(file_name);
  return im;
}

}  // namespace

TexcoordReadBack OsgbFormat::texcoord_read_back(const PageWriteOptions& /*page_options*/) const {
  return [](const Vec2& t) {
    return Vec2(stored_as_float32(t.x()), stored_as_float32(t.y()));
  };
}

WriteResult OsgbFormat::write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                              const std::string& stem, const PageWriteOptions& page_options,
                              OutputSet& files) const {
  auto* src = dynamic_cast<OsgbSource*>(in.source.get());
  const std::string out_name = output_name(stem);
  if (!src || in.format != name()) throw FormatError(in.path + ": not read by the osgb format");
  if (out_mesh.faces.size() != src->faces.size() || pages.size() != out_mesh.pages.size())
    throw FormatError(files.final_path(out_name) + ": the output mesh does not match " + in.path + " (" +
                      std::to_string(out_mesh.faces.size()) + " faces for " + std::to_string(src->faces.size()) + ")");
  WriteResult r;
  ScratchDir scratch;
  const std::string ext = page_options.format == ImageFormat::Jpeg ? "jpg" : "png";
  std::vector<osg::ref_ptr<osg::Image>> images;
  for (size_t p = 0; p < pages.size(); ++p) {
    const std::string file = stem + "_page" + std::to_string(p) + "." + ext;
    const std::string path = (fs::path(scratch.path) / file).string();
    write_page(path, pages, p, page_options);
    r.page_bytes += static_cast<size_t>(fs::file_size(path));
    std::error_code ec;
    if (fs::exists(file, ec))
      throw FormatError(files.final_path(out_name) + ": a file named " + file +
                        " in the working folder would be embedded instead of the page (osgDB looks there first); "
                        "run from another folder");
    images.push_back(osg_image(pages[p], file));
  }
  WriteCounts counts;
  TextureAssigner textures(images);
  for (const GeometryRecord& rec : src->geometries)
    if (rec.page != kNoPage) update_geometry(in.path, rec, src->faces, out_mesh, textures, counts);
  ClearReadFolder clear(src->folder);
  src->root->accept(clear);

  const std::string target = files.path_for(out_name);
  {
    // note: an embedded image file is read back from disk by osgDB's OutputStream through
    // findDataFile (the registry's data path list), so the scratch folder goes on that list for
    // the duration of the write.
    std::lock_guard<std::mutex> lock(osgb_detail::osgdb_mutex());  // osgb_source.h
    osgDB::FilePathList& paths = osgDB::Registry::instance()->getDataFilePathList();
    paths.push_front(scratch.path);
    osg::ref_ptr<osgDB::Options> opt = new osgDB::Options("WriteImageHint=IncludeFile");
    const osgDB::ReaderWriter::WriteResult wr = osgDB::Registry::instance()->writeNode(*src->root, target, opt.get());
    paths.erase(std::find(paths.begin(), paths.end(), scratch.path));
    if (!wr.success())
      throw FormatError(files.final_path(out_name) + ": cannot write the scene graph: " +
                        (wr.message().empty() ? std::string("no osgDB plugin writes .osgb (is osgdb_osg installed?)")
                                              : wr.message()));
  }
  r.main_file = files.final_path(out_name);
  r.files.push_back(r.main_file);
  r.report = {{"geometries", src->geometries.size()},
              {"vertices_added", counts.vertices_added},
              {"primitive_sets_reindexed", counts.primitive_sets_reindexed},
              {"primitive_sets_triangulated", counts.primitive_sets_triangulated},
              {"geometries_split", counts.geometries_split},
              {"geometries_added", counts.geometries_added},
              {"statesets_added", counts.statesets_added}};
  return r;
}

}  // namespace texdefrag
