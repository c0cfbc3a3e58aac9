// Wavefront OBJ + MTL reader and writer.
//
// Reader: v, vt (2 or 3 numbers; the third is ignored), vn, f (v, v/vt, v//vn, v/vt/vn, v/vt/ with an
// empty normal, negative indices, polygons fan-triangulated), usemtl, mtllib (several), g, o, s,
// comments, CRLF. MTL: newmtl, map_Kd with options (-bm 1 ...) and paths with spaces, resolved
// relative to the MTL's folder; every other line of a material is kept verbatim. Each material
// with a map_Kd is a page; page sizes are read from the image headers.
// Every error is an ObjError whose message is "FILE:LINE: what was expected"; nothing is skipped
// silently: unsupported statements (curves, `l`, `p`) are errors, not ignored.
//
// Details (docs/io.md has the full list):
// - pages are numbered in material definition order (mtllib order, then order in each MTL);
//   two materials naming the same image are two pages.
// - a face gets a page when it has texture coordinates and its material has a map_Kd; otherwise
//   kNoPage (faces without vt, with vt but no usemtl, or under a material without image).
// - `groups` holds the g/o statements that own faces, in order of first use; a bare `g` is the
//   default group (Face::group = kNoIndex). `s` is validated and not stored.
// - `v x y z w` is accepted only with w = 1; vertex colours are an error.
// - a token starting with '#' starts a comment, except in the names and paths that take the rest
//   of the line (usemtl, mtllib, newmtl, g, o, map_Kd), which are kept whole.
#pragma once

#include "texdefrag/core/mesh.h"

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

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
/// path: the OBJ file; MTL files are resolved relative to its folder, textures relative to each
///       MTL's folder, and Page::image_path is that folder joined with the map_Kd path.
/// options: see ObjReadOptions.
/// Cost: one pass over the file (about 30 ms CPU for the 46k-triangle, 4.5 MB t016_L19) plus one
/// image header per page.
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
/// mesh: must be consistent (indices in range, every corner of a face with or without vt/vn alike,
///       Face::page equal to the page its material and vt give on reading back, each page naming a
///       distinct material of the mesh, finite numbers, no face without material after one with a
///       material); otherwise ObjError and nothing is written. A material that no page names is
///       written without map_Kd (Material::map_kd is not used by the writer).
/// obj_path: the OBJ to write; its folder must exist. The MTL goes in the same folder.
/// options: MTL name and protected paths (compared as canonical paths, through symbolic links).
void write_obj(const TexturedMesh& mesh, const std::string& obj_path, const ObjWriteOptions& options = {});

/// Shortest decimal form of d that parses back to the same double ("%.17g" trimmed).
/// d: any finite double (-0 prints as "-0"); the text is std::to_chars' shortest round-trip form,
/// e.g. "0.1", "1", "1e-07".
std::string format_double(double d);

/// Writes `data` to `path` atomically (temporary file in the same folder, then rename).
/// Throws ObjError starting with `path` when the folder is missing or the write or rename fails;
/// the temporary file is removed on failure.
void write_file_atomic(const std::string& path, const std::string& data);
/// Same, the file being the concatenation of `pieces` (no copy into one string).
void write_file_atomic(const std::string& path, const std::vector<std::string>& pieces);
void write_file_atomic(const std::string& path, const std::vector<std::string_view>& pieces);

}  // namespace texdefrag
