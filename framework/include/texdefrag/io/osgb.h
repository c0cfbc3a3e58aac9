// OpenSceneGraph binary (.osgb) models, as ContextCapture/Smart3D delivers its tile pyramids,
// behind the ModelFormat interface. Read with osgDB::readNodeFile and a NodeVisitor; written back
// with osgDB::writeNodeFile, changing only texture coordinates (unit 0) and texture images.
//
// Reading (docs/io.md "OSGB"):
// - bounded (docs/io.md "OSGB: bounded reading"): osgDB sizes strings and arrays from the file
//   before reading them and crashes on some malformed files, so every file is first read by
//   osgDB in a child process under the limits of osgb_read_limits() (address space, CPU time, wall
//   time); only a file read there without error is read again in this process. A file that makes
//   that child fail, crash or exceed a limit is a FormatError naming the file and what happened.
// - every osg::Geometry reached from the root (each object once, even if shared) contributes its
//   vertex array (Vec3Array or Vec3dArray, kept exactly: float -> double is exact) to
//   mesh.positions, in traversal order; its faces follow in primitive-set order.
// - the texture of a geometry is the unit-0 texture of the nearest StateSet on its path (its own,
//   then its parents'); each distinct osg::Image is one page, decoded into LoadedModel::page_images.
//   The unit-0 texture coordinates (Vec2Array or Vec2dArray, per vertex) are mesh.texcoords. A
//   geometry without such a texture, image or texture coordinates is untextured (kNoPage): carried
//   through untouched.
// - primitive sets: DrawArrays, DrawArrayLengths, DrawElementsUByte/UShort/UInt, modes TRIANGLES,
//   TRIANGLE_STRIP (triangle i: (i, i+1, i+2), odd i as (i+1, i, i+2), as OpenGL draws it),
//   TRIANGLE_FAN ((0, i+1, i+2)), QUADS and QUAD_STRIP (two triangles each, as OpenGL splits them),
//   POLYGON (fan). Face::source_line is the primitive set's index + 1, Face::polygon_corner the
//   triangle's index within it. POINTS/LINES/patches in a textured geometry, instanced sets and a
//   TRIANGLES set whose index count is not a multiple of 3 are errors naming the file; in an
//   untextured geometry, non-triangle sets are carried through.
// - transforms are NOT applied: positions stay as stored, local to each geometry's frame (welding
//   across geometries under different transforms finds no shared positions there).
// - every external child a PagedLOD or ProxyNode names must exist beside the file (or under its
//   stored database path): a missing child is an error naming the child and the file.
//
// Writing: the scene graph read is written back (writeNodeFile, the same object structure, every
// node, PagedLOD centre, radius, range, child file name, transform and StateSet as read), with:
// - unit-0 texture coordinates replaced (same array type) and each texture's image replaced by its
//   output page, embedded as a JPEG or PNG file stream (WriteImageHint=IncludeFile), named
//   STEM_page<i>.<ext>;
// - a vertex whose faces need different output texture coordinates (charts that touched only at
//   that vertex and were packed apart) is duplicated: every per-vertex array gets a bit-identical
//   copy appended and the corners' indices point to it; a strip/fan/DrawArrays set whose shared
//   indices would need different copies is rewritten as DrawElementsUInt triangles (same faces,
//   same order and winding). Counted in the write report.
// - a geometry whose faces land on k > 1 output pages becomes k geometries in the same parents
//   (one per page, sharing the vertex arrays, StateSet copied with that page's texture).
// write() changes the scene graph held by `in.source`: a LoadedModel is written once.
#pragma once

#include "texdefrag/io/model_format.h"

#include <cstdint>
#include <optional>

namespace texdefrag {

/// What osgDB may use to read one OSGB file, in the child process that reads it first.
struct OsgbReadLimits {
  uint64_t memory_bytes = 0;  ///< address space the child may map beyond what it had at its start (RLIMIT_AS)
  double cpu_seconds = 0;     ///< CPU time of the child (RLIMIT_CPU, whole seconds, rounded up)
  double wall_seconds = 0;    ///< wall time after which the child is killed (a child blocked on a read)
};

/// Limits for a file of `file_bytes` bytes (documented constants, docs/io.md "OSGB: bounded
/// reading"): memory 512 MiB + 64 x the file, CPU 2 s + 2 s per MiB (rounded up to whole
/// seconds), wall 10 s + 4 x the CPU time. osgb_prod5's 31 files (up to 2.5 MB) take 0.06 CPU s
/// per file on average in the child and at most 23 MiB resident there.
OsgbReadLimits osgb_read_limits(uint64_t file_bytes);

/// Replaces osgb_read_limits() for every later OSGB read of this process (tests; a caller whose
/// files need more); std::nullopt restores the documented limits. Thread-safe.
void set_osgb_read_limits(std::optional<OsgbReadLimits> limits);

class OsgbFormat : public ModelFormat {
 public:
  std::string name() const override { return "osgb"; }
  /// By extension: ".osgb" in any case.
  bool can_read(const std::string& path) const override;
  LoadedModel read(const std::string& path) const override;
  std::string output_name(const std::string& stem) const override { return stem + ".osgb"; }
  WriteResult write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                    const std::string& stem, const PageWriteOptions& page_options,
                    OutputSet& files) const override;
  /// Float32 coordinates (osg::Vec2Array).
  TexcoordReadBack texcoord_read_back(const PageWriteOptions& page_options) const override;
};

/// External files an OSGB file references (PagedLOD children, ProxyNode files), as paths resolved
/// against the file's folder or the node's database path, in traversal order, each once.
/// Throws FormatError naming the file when it cannot be read.
std::vector<std::string> osgb_children(const std::string& path);

/// The .osgb files beside `path` (same folder, sorted) that name it as a child: their bytes hold
/// path's file name as a 32-bit length followed by the name, as OSGB stores PagedLOD and ProxyNode
/// file names. Reads bytes only (no osgDB, one file in memory at a time), so it works when `path`
/// itself is malformed: a production names the parent of a tile that fails. Unreadable files are
/// skipped.
std::vector<std::string> osgb_parents(const std::string& path);

}  // namespace texdefrag
