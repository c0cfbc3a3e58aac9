// OSGB reader (see texdefrag/io/osgb.h and docs/io.md "OSGB").
#include "osgb_source.h"
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/io/measure_transform.h"
#include "texdefrag/io/osgb.h"

#include <osg/NodeVisitor>
#include <osg/PagedLOD>
#include <osg/ProxyNode>
#include <osg/StateSet>
#include <osg/Transform>
#include <osgDB/FileNameUtils>
#include <osgDB/ReadFile>
#include <osgDB/Registry>

#include <algorithm>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <unordered_map>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

using osgb_detail::FaceRecord;
using osgb_detail::GeometryRecord;
using osgb_detail::OsgbSource;

/// Checks the binary OSGB header (the two magic words osgDB writes first) before osgDB sees the
/// bytes: a file that is not OSGB is an error naming it.
void check_osgb_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[8] = {};
  in.read(reinterpret_cast<char*>(h), sizeof h);
  static const unsigned char kMagic[8] = {0xA1, 0x0E, 0x91, 0x6C, 0x45, 0x45, 0xFB, 0x1A};  // 0x6C910EA1, 0x1AFB4545
  if (in.gcount() != 8 || !std::equal(h, h + 8, kMagic))
    throw FormatError(path + ": not a binary OSGB file (" + (in.gcount() < 8 ? std::string("shorter than its header") : std::string("bad magic")) + ")");
}

/// Reads a node file or throws FormatError with osgDB's reason: first in a bounded child process
/// (osgb_bounded.cpp), then, when that child read it, here.
osg::ref_ptr<osg::Node> read_node(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FormatError(path + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw FormatError(path + ": not a regular file");
  if (lower_extension(path) == "osgb") check_osgb_header(path);
  const uintmax_t bytes = fs::file_size(path, ec);
  std::lock_guard<std::mutex> lock(osgb_detail::osgdb_mutex());
  osgb_detail::read_in_bounded_child(path, osgb_detail::limits_for(ec ? 0 : static_cast<uint64_t>(bytes)));
  osgDB::ReaderWriter::ReadResult rr;
  try {
    rr = osgDB::Registry::instance()->readNode(path, nullptr);
  } catch (const std::exception& e) {
    // note: the child read the same bytes within its limits; this stays for a file changed since.
    throw FormatError(path + ": cannot read the scene graph (malformed OSGB?): " + e.what());
  }
  if (!rr.validNode()) {
    std::string why = rr.message();
    if (why.empty()) why = rr.notFound() ? "no osgDB plugin reads it (is osgdb_osg installed?)" : "unreadable or truncated";
    throw FormatError(path + ": cannot read the scene graph: " + why);
  }
  return rr.getNode();
}

/// Collects geometries with the unit-0 texture in force, and external children.
class Collector : public osg::NodeVisitor {
 public:
  Collector() : osg::NodeVisitor(TRAVERSE_ALL_CHILDREN) {}
  struct Found {
    osg::Geometry* geometry;
    osg::Texture* texture;
    osg::Matrixd world;  ///< local to world on the first path reaching the geometry (a shared one: that path's)
  };
  std::vector<Found> found;
  std::vector<std::pair<std::string, std::string>> children;  ///< (database path, file name)

  void apply(osg::Node& node) override {
    push(node.getStateSet());
    traverse(node);
    pop(node.getStateSet());
  }
  void apply(osg::PagedLOD& node) override {
    for (unsigned i = 0; i < node.getNumFileNames(); ++i)
      if (!node.getFileName(i).empty()) children.emplace_back(node.getDatabasePath(), node.getFileName(i));
    apply(static_cast<osg::Node&>(node));
  }
  void apply(osg::ProxyNode& node) override {
    for (unsigned i = 0; i < node.getNumFileNames(); ++i)
      if (!node.getFileName(i).empty()) children.emplace_back(node.getDatabasePath(), node.getFileName(i));
    apply(static_cast<osg::Node&>(node));
  }
  void apply(osg::Drawable& d) override {
    push(d.getStateSet());
    if (osg::Geometry* g = d.asGeometry())
      if (seen_.insert(g).second) found.push_back({g, texture_in_force(), osg::computeLocalToWorld(getNodePath())});
    pop(d.getStateSet());
  }

 private:
  void push(osg::StateSet* s) {
    if (s) stack_.push_back(s);
  }
  void pop(osg::StateSet* s) {
    if (s) stack_.pop_back();
  }
  osg::Texture* texture_in_force() const {
    for (auto it = stack_.rbegin(); it != stack_.rend(); ++it)
      if (auto* t = dynamic_cast<osg::Texture*>((*it)->getTextureAttribute(0, osg::StateAttribute::TEXTURE))) return t;
    return nullptr;
  }
  std::vector<osg::StateSet*> stack_;
  std::set<const osg::Geometry*> seen_;
};

/// Triangles of one run of `n` indices drawn with `mode`, as occurrence triples (base + i).
/// Returns false when the mode draws no triangles (points, lines, patches).
bool triangulate(GLenum mode, uint32_t base, uint32_t n, const std::function<void(uint32_t, uint32_t, uint32_t)>& tri,
                 std::string& why) {
  switch (mode) {
    case GL_TRIANGLES:
      if (n % 3) {
        why = "a TRIANGLES set of " + std::to_string(n) + " indices (not a multiple of 3)";
        return false;
      }
      for (uint32_t i = 0; i + 2 < n; i += 3) tri(base + i, base + i + 1, base + i + 2);
      return true;
    case GL_TRIANGLE_STRIP:
      for (uint32_t i = 0; i + 2 < n; ++i)
        if (i % 2) tri(base + i + 1, base + i, base + i + 2);
        else tri(base + i, base + i + 1, base + i + 2);
      return true;
    case GL_TRIANGLE_FAN:
    case GL_POLYGON:
      for (uint32_t i = 1; i + 1 < n; ++i) tri(base, base + i, base + i + 1);
      return true;
    case GL_QUADS:
      for (uint32_t i = 0; i + 3 < n; i += 4) {
        tri(base + i, base + i + 1, base + i + 2);
        tri(base + i, base + i + 2, base + i + 3);
      }
      return true;
    case GL_QUAD_STRIP:  // quad k = (2k, 2k+1, 2k+3, 2k+2)
      for (uint32_t i = 0; i + 3 < n; i += 2) {
        tri(base + i, base + i + 1, base + i + 3);
        tri(base + i, base + i + 3, base + i + 2);
      }
      return true;
    default:
      why = "primitive mode " + std::to_string(mode) + " (points, lines or patches)";
      return false;
  }
}

/// Positions of a vertex array as doubles (exact), or throws naming the file.
void append_positions(const std::string& path, const osg::Array* a, std::vector<Vec3>& out) {
  if (const auto* f = dynamic_cast<const osg::Vec3Array*>(a)) {
    for (const osg::Vec3f& v : *f) out.emplace_back(v.x(), v.y(), v.z());
  } else if (const auto* d = dynamic_cast<const osg::Vec3dArray*>(a)) {
    for (const osg::Vec3d& v : *d) out.emplace_back(v.x(), v.y(), v.z());
  } else {
    throw FormatError(path + ": a geometry's vertex array is " + (a ? a->className() : std::string("missing")) +
                      " (expected Vec3Array or Vec3dArray)");
  }
}

/// Unit-0 texture coordinates as doubles, or false when the array is absent / not per vertex.
bool append_texcoords(const std::string& path, const osg::Array* a, size_t vertices, std::vector<Vec2>& out) {
  if (!a) return false;
  if (a->getBinding() != osg::Array::BIND_PER_VERTEX && a->getBinding() != osg::Array::BIND_UNDEFINED) return false;
  if (a->getNumElements() != vertices)
    throw FormatError(path + ": a textured geometry has " + std::to_string(a->getNumElements()) +
                      " texture coordinates for " + std::to_string(vertices) + " vertices");
  if (const auto* f = dynamic_cast<const osg::Vec2Array*>(a)) {
    for (const osg::Vec2f& v : *f) out.emplace_back(v.x(), v.y());
  } else if (const auto* d = dynamic_cast<const osg::Vec2dArray*>(a)) {
    for (const osg::Vec2d& v : *d) out.emplace_back(v.x(), v.y());
  } else {
    throw FormatError(path + ": unit-0 texture coordinates are " + std::string(a->className()) +
                      " (expected Vec2Array or Vec2dArray)");
  }
  return true;
}

/// Bytes level 0 of `im` spans in memory: rows of getRowStepInBytes(), the last one only its
/// pixels. Requires im.s() and im.t() >= 1 (check_image_buffer checks them first).
size_t level0_bytes(const osg::Image& im, int channels) {
  return static_cast<size_t>(im.getRowStepInBytes()) * static_cast<size_t>(im.t() - 1) +
         static_cast<size_t>(im.s()) * static_cast<size_t>(channels);
}

/// Throws unless `im`'s declared sizes and packing describe a buffer its data holds. osgDB takes an
/// inline image's width, height, packing and byte count from the file independently (its
/// InputStream::readImage), so a malformed file declares more pixels (or a row packing of
/// thousands of bytes) than the bytes that follow: reading them ran past the buffer (fuzz_osgb).
/// The buffer's size is the allocator's (malloc_usable_size: osgDB and its image plugins allocate
/// with new[], which is malloc in glibc; the allocator may round a size up by a few bytes, which a
/// read then stays inside).
void check_image_buffer(const std::string& path, const osg::Image& im, int channels) {
  const std::string what = path + ": texture image '" + im.getFileName() + "'";
  const unsigned int packing = im.getPacking();
  if (packing != 1 && packing != 2 && packing != 4 && packing != 8)
    throw FormatError(what + " has row packing " + std::to_string(packing) + " (expected 1, 2, 4 or 8)");
  constexpr int kMaxSide = 1 << 16;
  if (im.s() <= 0 || im.t() <= 0 || im.s() > kMaxSide || im.t() > kMaxSide)
    throw FormatError(what + " is " + std::to_string(im.s()) + " x " + std::to_string(im.t()) +
                      " pixels (expected 1 to " + std::to_string(kMaxSide) + " a side)");
#ifdef __GLIBC__
  const size_t held = malloc_usable_size(const_cast<unsigned char*>(im.data()));
  const size_t needed = level0_bytes(im, channels);
  if (held < needed)
    throw FormatError(what + " declares " + std::to_string(im.s()) + " x " + std::to_string(im.t()) + " pixels of " +
                      std::to_string(channels) + " bytes (packing " + std::to_string(packing) + ": " +
                      std::to_string(needed) + " bytes) but holds " + std::to_string(held) +
                      " bytes: the file is malformed");
#endif
}

/// Decodes an osg::Image (8-bit, 1-4 channels) into an Image, rows top to bottom (OpenGL draws
/// memory row 0 at t = 0, the bottom). Throws FormatError naming `path` and the image when its
/// pixels are of another kind or its buffer is smaller than its declared sizes.
Image to_image(const std::string& path, const osg::Image& im) {
  int channels = 0;
  switch (im.getPixelFormat()) {
    case GL_LUMINANCE: case GL_RED: channels = 1; break;
    case GL_LUMINANCE_ALPHA: case GL_RG: channels = 2; break;
    case GL_RGB: channels = 3; break;
    case GL_RGBA: channels = 4; break;
    default: break;
  }
  if (!channels || im.getDataType() != GL_UNSIGNED_BYTE || im.r() != 1 || !im.data())
    throw FormatError(path + ": texture image '" + im.getFileName() + "' has pixel format " +
                      std::to_string(im.getPixelFormat()) + ", type " + std::to_string(im.getDataType()) +
                      " (expected 8-bit luminance, RG, RGB or RGBA pixels)");
  check_image_buffer(path, im, channels);
  Image out;
  out.width = im.s();
  out.height = im.t();
  out.channels = channels;
  const size_t row = static_cast<size_t>(out.width) * static_cast<size_t>(channels);
  out.pixels.resize(row * static_cast<size_t>(out.height));
  const size_t step = im.getRowStepInBytes();  // note: osg::Image::data(col, row) multiplies in 32 bits
  for (int y = 0; y < out.height; ++y) {
    const unsigned char* src = im.data() + step * static_cast<size_t>(out.height - 1 - y);
    std::copy(src, src + row, out.pixels.begin() + static_cast<long>(row * static_cast<size_t>(y)));
  }
  return out;
}

/// Embedded image streams of an .osgb file, in file order: the binary format writes an inline
/// file as its 32-bit size followed by the bytes, so a JPEG (PNG) is recognised by its signature
/// preceded by a size whose end is an EOI marker (IEND chunk).
std::vector<PageEncoding> embedded_streams(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto* b = reinterpret_cast<const uint8_t*>(data.data());
  std::vector<PageEncoding> out;
  for (size_t i = 4; i + 8 < data.size(); ++i) {
    const bool jpeg = b[i] == 0xFF && b[i + 1] == 0xD8 && b[i + 2] == 0xFF;
    const bool png = b[i] == 0x89 && b[i + 1] == 'P' && b[i + 2] == 'N' && b[i + 3] == 'G';
    if (!jpeg && !png) continue;
    const size_t n = static_cast<size_t>(b[i - 4]) | static_cast<size_t>(b[i - 3]) << 8 |
                     static_cast<size_t>(b[i - 2]) << 16 | static_cast<size_t>(b[i - 1]) << 24;
    if (n < 8 || i + n > data.size()) continue;
    if (jpeg && !(b[i + n - 2] == 0xFF && b[i + n - 1] == 0xD9)) continue;
    if (png && data.compare(i + n - 8, 4, "IEND") != 0) continue;
    PageEncoding e;
    e.format = jpeg ? "jpeg" : "png";
    e.bytes = n;
    if (jpeg) {
      e.jpeg_quality = estimate_jpeg_quality(b + i, n);
      e.jpeg_subsampling = read_jpeg_subsampling(b + i, n);
    }
    e.bits = image_bits_of_stream(b + i, n);
    out.push_back(e);
    i += n - 1;
  }
  return out;
}

std::string resolve_child(const std::string& folder, const std::string& database_path, const std::string& name) {
  if (fs::path(name).is_absolute()) return name;
  const std::string base = database_path.empty() ? folder : database_path;
  return (fs::path(base) / name).lexically_normal().string();
}

}  // namespace

bool OsgbFormat::can_read(const std::string& path) const { return lower_extension(path) == "osgb"; }

std::vector<std::string> osgb_children(const std::string& path) {
  osg::ref_ptr<osg::Node> root = read_node(path);
  Collector c;
  root->accept(c);
  const std::string folder = fs::path(path).parent_path().string();
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (const auto& [db, name] : c.children) {
    const std::string p = resolve_child(folder.empty() ? "." : folder, db, name);
    if (seen.insert(p).second) out.push_back(p);
  }
  return out;
}

std::vector<std::string> osgb_parents(const std::string& path) {
  const fs::path file(path);
  const std::string name = file.filename().string();
  std::string needle(4, '\0');
  for (size_t i = 0; i < 4; ++i) needle[i] = static_cast<char>((name.size() >> (8 * i)) & 0xFF);
  needle += name;
  std::vector<std::string> out;
  std::error_code ec;
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  for (auto it = fs::directory_iterator(folder, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    if (lower_extension(it->path().string()) != "osgb" || it->path().filename() == file.filename()) continue;
    std::ifstream in(it->path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (bytes.find(needle) != std::string::npos) out.push_back(it->path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

/// Appends the faces of one geometry's primitive sets to the mesh and the face records.
void read_faces(const std::string& path, const GeometryRecord& rec, uint32_t geometry_index, int position_offset,
                int texcoord_offset, TexturedMesh& mesh, std::vector<FaceRecord>& records) {
  const osg::Geometry& g = *rec.geometry;
  const uint32_t vertices = g.getVertexArray()->getNumElements();
  const bool textured = rec.page != kNoPage;
  for (uint32_t s = 0; s < g.getNumPrimitiveSets(); ++s) {
    const osg::PrimitiveSet& ps = *g.getPrimitiveSet(s);
    const std::string where = path + ": primitive set " + std::to_string(s) + " (" + ps.className() + ") of a " +
                              (textured ? "textured" : "untextured") + " geometry";
    const auto type = ps.getType();
    const bool known = type == osg::PrimitiveSet::DrawArraysPrimitiveType ||
                       type == osg::PrimitiveSet::DrawArrayLengthsPrimitiveType ||
                       type == osg::PrimitiveSet::DrawElementsUBytePrimitiveType ||
                       type == osg::PrimitiveSet::DrawElementsUShortPrimitiveType ||
                       type == osg::PrimitiveSet::DrawElementsUIntPrimitiveType;
    if (!known || ps.getNumInstances() > 0) {
      if (!textured) continue;  // carried through untouched
      throw FormatError(where + ": unsupported (" + (known ? "instanced" : "indirect or multi-draw") + ")");
    }
    int corner = 0;
    auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
      Face f;
      FaceRecord r;
      r.geometry = geometry_index;
      r.primitive_set = s;
      r.occurrence = {a, b, c};
      for (int k = 0; k < 3; ++k) {
        const uint32_t vi = ps.index(r.occurrence[static_cast<size_t>(k)]);
        if (vi >= vertices)
          throw FormatError(where + ": index " + std::to_string(vi) + " out of range (" + std::to_string(vertices) +
                            " vertices)");
        f.v[static_cast<size_t>(k)] = position_offset + static_cast<int>(vi);
        if (textured) f.vt[static_cast<size_t>(k)] = texcoord_offset + static_cast<int>(vi);
      }
      f.page = rec.page;
      f.material = textured ? rec.page : kNoIndex;
      f.source_line = static_cast<int>(s) + 1;
      f.polygon_corner = corner++;
      mesh.faces.push_back(f);
      records.push_back(r);
    };
    std::string why;
    bool ok = true;
    if (const auto* lengths = dynamic_cast<const osg::DrawArrayLengths*>(&ps)) {
      uint32_t base = 0;
      for (GLint n : *lengths) {
        ok = ok && triangulate(ps.getMode(), base, static_cast<uint32_t>(n), tri, why);
        base += static_cast<uint32_t>(n);
      }
    } else {
      ok = triangulate(ps.getMode(), 0, ps.getNumIndices(), tri, why);
    }
    if (!ok && textured) throw FormatError(where + ": unsupported " + why);
    // note: an untextured geometry's point and line sets are carried through untouched.
  }
}

/// Gives each distinct image a page; decodes it.
int page_of(const std::string& path, osg::Image* image, LoadedModel& m, OsgbSource& src,
            std::map<const osg::Image*, int>& pages) {
  const auto it = pages.find(image);
  if (it != pages.end()) return it->second;
  const int p = static_cast<int>(src.images.size());
  pages.emplace(image, p);
  src.images.push_back(image);
  m.page_images.push_back(to_image(path, *image));
  Material mat;
  mat.name = "texture_" + std::to_string(p);
  m.mesh.materials.push_back(mat);
  Page page;
  page.material = mat.name;
  page.image_path = path + "#" + image->getFileName();
  page.width = image->s();
  page.height = image->t();
  m.mesh.pages.push_back(page);
  PageEncoding enc;
  const std::string ext = lower_extension(image->getFileName());
  enc.format = ext == "jpg" ? "jpeg" : ext;
  m.page_encodings.push_back(enc);
  const std::string external = (fs::path(src.folder) / image->getFileName()).string();
  std::error_code ec;
  if (!image->getFileName().empty() && fs::is_regular_file(external, ec)) m.input_files.push_back(external);
  return p;
}

/// Fills page encodings from the file's embedded streams (in file order, which is the traversal
/// order of the images); when they do not pair up one to one, every JPEG page gets the largest
/// estimated quality and an unknown size.
void match_streams(const std::string& path, LoadedModel& m) {
  const std::vector<PageEncoding> streams = embedded_streams(path);
  bool paired = streams.size() == m.page_encodings.size();
  for (size_t p = 0; paired && p < streams.size(); ++p) paired = streams[p].format == m.page_encodings[p].format;
  if (paired) {
    m.page_encodings = streams;
    return;
  }
  std::optional<int> q;
  std::optional<JpegSubsampling> s;
  for (const PageEncoding& e : streams) {
    if (e.jpeg_quality) q = std::max(q.value_or(1), *e.jpeg_quality);
    if (e.jpeg_subsampling) s = std::min(s.value_or(JpegSubsampling::S420), *e.jpeg_subsampling);
  }
  for (PageEncoding& e : m.page_encodings)
    if (e.format == "jpeg") {
      e.jpeg_quality = q;
      e.jpeg_subsampling = s;
    }
}

}  // namespace

LoadedModel OsgbFormat::read(const std::string& path) const {
  auto src = std::make_shared<OsgbSource>();
  src->root = read_node(path);
  src->folder = fs::path(path).parent_path().string();
  if (src->folder.empty()) src->folder = ".";
  Collector c;
  src->root->accept(c);
  LoadedModel m;
  for (const auto& [db, name] : c.children) {
    const std::string child = resolve_child(src->folder, db, name);
    std::error_code ec;
    if (!fs::is_regular_file(child, ec)) m.missing_files.push_back(child + ": no such file (child '" + name + "' of " + path + ")");
  }
  m.path = path;
  m.format = name();
  m.input_files.push_back(path);
  std::map<const osg::Image*, int> pages;
  for (const Collector::Found& f : c.found) {
    GeometryRecord rec;
    rec.geometry = f.geometry;
    const osg::Array* va = f.geometry->getVertexArray();
    if (!va) continue;  // nothing drawn
    const int position_offset = static_cast<int>(m.mesh.positions.size());
    append_positions(path, va, m.mesh.positions);
    // Measured as the user sees them (io/measure_transform.h); written back from the stored array.
    Mat3 linear;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) linear(i, j) = f.world(j, i);  // OSG multiplies row vectors: v' = v M
    m.positions_stretched += apply_stretch(m.mesh.positions, static_cast<size_t>(position_offset), stretch_part(linear));
    const int texcoord_offset = static_cast<int>(m.mesh.texcoords.size());
    if (f.texture) {
      osg::Image* image = f.texture->getImage(0);
      if (!image)
        throw FormatError(path + ": a geometry's texture has no image (an external image file that was not found?)");
      if (append_texcoords(path, f.geometry->getTexCoordArray(0), va->getNumElements(), m.mesh.texcoords)) {
        rec.texture = f.texture;
        rec.page = page_of(path, image, m, *src, pages);
      }
    }
    rec.first_face = m.mesh.faces.size();
    read_faces(path, rec, static_cast<uint32_t>(src->geometries.size()), position_offset, texcoord_offset, m.mesh,
               src->faces);
    rec.num_faces = m.mesh.faces.size() - rec.first_face;
    src->geometries.push_back(rec);
  }
  match_streams(path, m);
  m.source = src;
  return m;
}

}  // namespace texdefrag
