// Textured triangle mesh as read from an OBJ/MTL: the data model every stage works on.
//
// Contract (holds for every TexturedMesh the reader returns and the writer accepts):
// - positions are kept exactly as parsed (double); the writer prints them so they read back
//   bit-identical. Positions are NOT welded here: real photogrammetry exports duplicate a position at
//   every UV seam, so 3D adjacency is recovered separately (core/topology.h).
// - faces are triangles; polygons in the input are fan-triangulated by the reader, and
//   Face::source_line / Face::polygon_corner record where each triangle came from.
// - each face has a page index (texture page = material with a map_Kd image) or kNoPage for faces
//   with no texture coordinates; such faces are carried through untouched.
// - per-corner texture coordinates are indices into `texcoords` (normalised OBJ (u, v), v up).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace texdefrag {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

constexpr int kNoPage = -1;
constexpr int kNoIndex = -1;

/// One material of the MTL. A material with a diffuse map is a texture page.
struct Material {
  std::string name;
  /// Lines of the material block exactly as read (minus map_Kd), written back unchanged.
  std::vector<std::string> extra_lines;
  /// map_Kd path as written in the MTL (relative to the MTL's folder), empty if none.
  std::string map_kd;
  /// map_Kd options before the path (e.g. "-bm 1"), kept verbatim.
  std::string map_kd_options;
  /// The map_Kd's `-clamp on` (clamp-to-edge addressing); false for `-clamp off` or none (repeat).
  bool clamp = false;
};

/// A texture page: one image. Pages are numbered 0..pages.size()-1.
struct Page {
  std::string material;    ///< name of the material that owns the image
  std::string image_path;  ///< absolute or working-directory-relative path of the image file
  int width = 0;           ///< pixels; 0 until known (the reader fills it from the image header)
  int height = 0;          ///< pixels
  /// Texture addressing outside [0, 1]: false = repeat (the MTL default, `-clamp off`), true =
  /// clamp to the edge (`map_Kd -clamp on`). Resampling reads the page this way.
  bool clamp = false;
};

struct Face {
  std::array<int, 3> v{kNoIndex, kNoIndex, kNoIndex};   ///< indices into positions
  std::array<int, 3> vt{kNoIndex, kNoIndex, kNoIndex};  ///< indices into texcoords, kNoIndex if absent
  std::array<int, 3> vn{kNoIndex, kNoIndex, kNoIndex};  ///< indices into normals, kNoIndex if absent
  int material = kNoIndex;  ///< index into materials (usemtl), kNoIndex if none
  int page = kNoPage;       ///< texture page, kNoPage when untextured
  int group = kNoIndex;     ///< index into groups (the `g`/`o` line in force), kNoIndex if none
  int source_line = 0;      ///< 1-based line of the `f` statement in the OBJ
  int polygon_corner = 0;   ///< 0 for a triangle; k for the k-th triangle of a fan-split polygon
};

struct TexturedMesh {
  std::vector<Vec3> positions;
  /// Vertex colours (`v x y z r g b`, as Metashape, RealityCapture and MeshLab may write them), one
  /// per position, kept exactly as parsed and written back with their position; empty when the OBJ
  /// has none. Either every `v` line of an OBJ has a colour or none has (the reader refuses a mix).
  std::vector<Vec3> colors;
  std::vector<Vec2> texcoords;  ///< normalised (u, v), v up, as in the OBJ
  std::vector<Vec3> normals;
  std::vector<Face> faces;
  std::vector<Material> materials;
  std::vector<Page> pages;
  std::vector<std::string> groups;  ///< `g`/`o` statements, verbatim (e.g. "g roof")
  /// Every file the reader read or the mesh references (OBJ, MTLs, page images), as the reader
  /// resolved them. The write service (io/output_set.h) never writes onto any of them.
  std::vector<std::string> source_files;

  /// Number of triangles.
  size_t num_faces() const { return faces.size(); }

  /// Texture coordinate of corner k of face f in texels of its page (x = u*W, y = v*H, y up).
  /// Requires faces[f].page != kNoPage and the page size known.
  Vec2 corner_texel(size_t f, int k) const {
    const Face& fc = faces[f];
    const Page& p = pages[static_cast<size_t>(fc.page)];
    const Vec2& t = texcoords[static_cast<size_t>(fc.vt[k])];
    return {t.x() * p.width, t.y() * p.height};
  }
  const Vec3& corner_position(size_t f, int k) const {
    return positions[static_cast<size_t>(faces[f].v[k])];
  }
};

}  // namespace texdefrag
