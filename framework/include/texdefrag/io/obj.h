// Wavefront OBJ + MTL reader and writer.
//
// Reader: v, vt (2 or 3 numbers; the third is ignored), vn, f (v, v/vt, v//vn, v/vt/vn, v/vt/ with an
// empty normal, negative indices, polygons fan-triangulated), usemtl, mtllib (several), g, o, s,
// comments, CRLF. MTL: newmtl, map_Kd with options (-bm 1 ...) and paths with spaces, resolved
// relative to the MTL's folder; every other line of a material is kept verbatim. Each material
// with a map_Kd is a page; page sizes are read from the image headers.
// Every error is an ObjError whose message is "FILE:LINE: what was expected"; nothing is skipped
// silently: unsupported statements (curves, `l`, `p`) are errors, not ignored.
#pragma once

#include "texdefrag/core/mesh.h"

#include <stdexcept>
#include <string>

namespace texdefrag {

struct ObjError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ObjReadOptions {
  /// Read each page's image header for its size (needed by every stage; off only for tests).
  bool read_page_sizes = true;
  /// Treat a missing texture image as an error (default). When false, the page keeps size 0.
  bool require_textures = true;
};

/// Reads an OBJ and its MTL files. Throws ObjError naming file and line on malformed input, a
/// missing MTL or texture, an index out of range, or a non-finite number.
TexturedMesh read_obj(const std::string& path, const ObjReadOptions& options = {});

struct ObjWriteOptions {
  /// File name of the MTL written beside the OBJ (default: OBJ stem + ".mtl").
  std::string mtl_name;
  /// Paths that must never be overwritten (the inputs). Writing onto one throws ObjError.
  std::vector<std::string> protected_paths;
};

/// Writes mesh as OBJ + MTL. Positions, normals and texture coordinates are printed in the
/// shortest form that reads back bit-identical. Faces are written in order with their material and
/// group. Each page's material gets `map_Kd <file name of Page::image_path>`. Files are written to a
/// temporary name and renamed, so a failed write leaves no partial file. Images are not written.
void write_obj(const TexturedMesh& mesh, const std::string& obj_path, const ObjWriteOptions& options = {});

/// Shortest decimal form of d that parses back to the same double ("%.17g" trimmed).
std::string format_double(double d);

/// Writes `data` to `path` atomically (temporary file in the same folder, then rename).
void write_file_atomic(const std::string& path, const std::string& data);

}  // namespace texdefrag
