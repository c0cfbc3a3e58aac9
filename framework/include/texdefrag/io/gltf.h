// glTF 2.0 (.gltf, .glb) reader and writer: one or several files read as one model, written back as
// the same assets with new texture coordinates and page images (docs/io.md, "glTF").
//
// Reading goes through tinygltf (Debian's libtinygltf, images not decoded by it) and Draco
// (KHR_draco_mesh_compression, always decoded). Every triangle primitive (modes TRIANGLES,
// TRIANGLE_STRIP, TRIANGLE_FAN; strips and fans are triangulated, docs/io.md) becomes faces of one
// TexturedMesh, file by file, mesh by mesh, primitive by primitive, in index order. A primitive is
// textured when its material has a baseColorTexture; that texture's image is a page. Pages are
// keyed by image: several materials or several files naming the same image share one page (this is
// how one atlas shared by several GLBs of a 3D Tiles level becomes one page set). A
// KHR_texture_basisu (KTX2) image is replaced by a JPEG/PNG source when one exists (the texture's
// core `source`, the image's `name` naming a file beside it, or the URI with .jpg/.jpeg/.png);
// otherwise it is an error naming the file.
//
// Writing edits the original JSON (key order, numbers, extras and extensions kept exactly, which
// tinygltf's own writer does not do: it truncates integers above 2^31, drops empty objects and
// sorts keys) and rebuilds the binary buffer: only the rewritten primitives' accessors, the page
// textures/images and the materials of textured primitives change; nodes, matrices, scenes, other
// primitives, extras and unknown extensions are kept. Every face keeps its corner positions byte for
// byte and its order inside its primitive.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/measure_transform.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

/// Malformed or unsupported glTF input, or an impossible write. The message starts with the file.
struct GltfError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One glTF document to read: a file, or bytes held in memory (a GLB cut out of a b3dm).
struct GltfInput {
  std::string path;             ///< file path; for in-memory input, the name used in errors
  std::vector<uint8_t> bytes;   ///< empty: read `path`; else the GLB or glTF JSON bytes
  std::string base_dir;         ///< folder external URIs resolve against (default: path's folder)
  /// Linear part of the transform above the document's scenes, for measuring only (docs/io.md
  /// "Node transforms"): a 3D Tiles content's tile transforms times the glTF y-up to z-up turn;
  /// the identity for a plain glTF file.
  Mat3 outer_linear = Mat3::Identity();
};

/// Where face `f` of GltfModel::mesh came from.
struct GltfFaceSource {
  int file = 0;       ///< index into GltfModel::inputs
  int mesh = 0;       ///< glTF mesh index in that file
  int primitive = 0;  ///< primitive index in that mesh
  int triangle = 0;   ///< triangle index inside the (triangulated) primitive
};

/// Where page `p` of GltfModel::mesh comes from.
struct GltfPageSource {
  std::string image_file;        ///< readable JPEG/PNG file, or "" when the image is embedded
  std::vector<uint8_t> embedded; ///< encoded bytes of an embedded image (GLB bufferView, data URI)
  std::string mime;              ///< "image/jpeg" or "image/png"
  std::string replaces_ktx2;     ///< the KTX2 file or URI this JPEG/PNG stands in for, if any
  std::string label;             ///< "FILE image N" for messages
};

namespace gltf_detail {
struct Document;  // one parsed file (tinygltf model, original JSON, decoded primitives)
}

/// One or more glTF files read as one model.
struct GltfModel {
  std::vector<GltfInput> inputs;              ///< as given (bytes dropped after reading)
  TexturedMesh mesh;                          ///< all triangle primitives of all files
  std::vector<GltfFaceSource> face_source;    ///< one per face of `mesh`
  std::vector<GltfPageSource> page_source;    ///< one per page of `mesh`
  nlohmann::json stats;                       ///< numbers for the run report's read node
  /// Positions multiplied by their node transform's stretch for measuring (io/measure_transform.h):
  /// mesh.positions are the accessor values times the stretch of (outer_linear * the linear part
  /// of the first node naming their glTF mesh); the writer writes the accessors' bytes.
  size_t positions_stretched = 0;
  std::shared_ptr<const std::vector<gltf_detail::Document>> documents;  ///< for the writer
};

struct GltfReadOptions {
  /// Read each page's image header for its size (needed by every stage; off only for tests).
  bool read_page_sizes = true;
};

/// Reads the files as one model (see the file comment for what becomes faces and pages).
/// inputs: one or more documents; URIs resolve against each one's base_dir.
/// Throws GltfError naming the file (and the object: "mesh 0 primitive 1", "accessor 3") on a bad
/// GLB header or chunk, JSON errors, an accessor or index out of range, a non-finite position or
/// texture coordinate, a Draco buffer that does not decode, points/lines with a textured material,
/// a KTX2-only texture without a JPEG/PNG source, a missing image, sparse or EXT_meshopt data in a
/// textured primitive, a material with other textures on the base colour's texture coordinates.
GltfModel read_gltf(const std::vector<GltfInput>& inputs, const GltfReadOptions& options = {});
/// Convenience: one file.
GltfModel read_gltf(const std::string& path, const GltfReadOptions& options = {});

/// Decodes page `page` of `model` (from its file, or from its embedded bytes). Throws ImageError.
Image read_gltf_page(const GltfModel& model, int page);

/// How rewritten primitives are stored.
enum class DracoOutput {
  None,       ///< uncompressed accessors (default; positions and face order exact by construction)
  Lossless,   ///< KHR_draco_mesh_compression, sequential connectivity, positions not quantised:
              ///< decodes to the same positions bit for bit and the same face order (verified)
  Quantized,  ///< sequential connectivity, positions quantised: exact when the input primitive
              ///< was Draco-quantised (its own origin, range and bits are reused), else lossy
              ///< at `draco_position_bits` (the write report counts changed positions)
};

struct GltfWriteOptions {
  DracoOutput draco = DracoOutput::None;
  int draco_position_bits = 16;  ///< [8, 30]; Quantized only, for inputs not already quantised
  int draco_texcoord_bits = 16;  ///< [8, 30]; Lossless and Quantized: texture coordinates
  int draco_generic_bits = 16;   ///< [8, 30]; Quantized: other float attributes (normals, ...)
};

/// An encoded output page.
struct EncodedPage {
  std::string mime;             ///< "image/jpeg" or "image/png"
  std::vector<uint8_t> bytes;
};

/// A file the writer produced, to be written by the caller (through its output set).
struct OutputFile {
  std::string path;
  std::string bytes;
};

struct GltfOutput {
  /// One per input, in order: the new GLB bytes (for a GLB input) or glTF JSON text (.gltf).
  std::vector<std::string> documents;
  /// Files the documents refer to: external page images and external buffers.
  std::vector<OutputFile> files;
  nlohmann::json report;  ///< numbers for the run report's write node
};

/// Paths of the output: where input file i goes, and where an external input file (an image or a
/// buffer it refers to) goes. Both map an input path to an output path.
struct GltfOutputPaths {
  std::vector<std::string> documents;                        ///< one per input
  std::function<std::string(const std::string&)> map_path;   ///< input file -> output file
};

/// Builds the output of `in` with the texture coordinates and pages of `out`.
/// out: the pipeline's output mesh (make_output_mesh): same faces, in order, as in.mesh, each
///      textured face with its output page and normalised (u, v) texture coordinates (v up).
/// pages: one encoded image per page of `out`.
/// paths: output places; page images that were external files go to
///        map_path(<input image folder>/<name>), named after the input image (page 0 keeps the
///        input's stem, page k > 0 gets "_<k>"; the extension follows the format).
/// Throws GltfError naming the file when the mesh does not match the input or a part cannot be
/// written (morph targets with Draco output, a primitive whose vertex count needs more than 32-bit
/// indices).
GltfOutput write_gltf(const GltfModel& in, const TexturedMesh& out, const std::vector<EncodedPage>& pages,
                      const GltfOutputPaths& paths, const GltfWriteOptions& options = {});

/// Groups documents that share an external image file (by normalised path, KTX2 images and their
/// JPEG/PNG stand-ins alike): each group must be read as one model so that the shared atlas stays
/// one atlas. Groups and their members keep the input order. Reads only each document's JSON;
/// throws GltfError naming the file when it is not a GLB or glTF JSON.
/// image_files: when given, filled with one list per input of the existing image files it may read
/// (each external image URI, and the JPEG/PNG stand-ins of a KTX2 image: its `name` beside the
/// document, the URI with .jpg/.jpeg/.png), for input hashes.
/// unreadable: when given, a document that cannot be read is not an error: its message is appended
/// here and it is a group of its own (reading it as a model later fails with that error).
std::vector<std::vector<size_t>> gltf_shared_image_groups(const std::vector<GltfInput>& inputs,
                                                          std::vector<std::vector<std::string>>* image_files = nullptr,
                                                          std::vector<std::string>* unreadable = nullptr);

/// True when `bytes` start with the GLB magic "glTF".
bool is_glb(const std::vector<uint8_t>& bytes);

}  // namespace texdefrag
