// 3D Tiles in and out (docs/io.md, "3D Tiles"): a tileset.json (1.0 with b3dm or
// 3DTILES_content_gltf, 1.1 with glTF/GLB content), its external tilesets and every content, read
// as a production and written back with the same layout. Contents that share an atlas (an
// external image named by several GLBs, as a level of Matterport tilesets does) are one model.
// Tileset JSON keeps every tile, transform, bounding volume, geometric error and refine; b3dm keep
// their feature and batch tables byte for byte, only the GLB inside changes.
#pragma once

#include "texdefrag/io/measure_transform.h"
#include "texdefrag/pipeline/pipeline.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

/// A malformed or incomplete tileset; the message names the file and the tileset naming it.
struct TilesetError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One content of a tile.
struct TilesetContent {
  std::string uri;      ///< as written in the tileset
  std::string path;     ///< resolved file
  std::string tileset;  ///< the tileset JSON that names it
  std::string kind;     ///< "glb", "gltf", "b3dm", or the lower-case extension of other contents
  /// Linear part of the transform from the content's glTF frame to the entry tileset's frame: the
  /// tile transforms from the root down to its tile (through external tilesets) times the glTF
  /// up-axis turn (asset.gltfUpAxis, default y-up to z-up). Translations (tile transforms', a
  /// b3dm's RTC_CENTER, CESIUM_RTC) change no length, angle or area and are left out. For
  /// measuring only (GltfInput::outer_linear; docs/io.md "Node transforms").
  Mat3 measure_linear = Mat3::Identity();
};

/// A content or external tileset of the tree that cannot be read (missing file, unreadable or
/// invalid external tileset JSON), kept aside by read_tileset(path, true).
struct TilesetBroken {
  std::string path;     ///< the file as resolved
  std::string tileset;  ///< the tileset JSON naming it
  std::string error;    ///< the error read_tileset(path) throws for it, naming both
};

struct Tileset {
  std::string path;                      ///< the entry tileset JSON
  std::vector<std::string> tilesets;     ///< every tileset JSON, entry first, then external ones as reached
  std::vector<TilesetContent> contents;  ///< every content that is not an external tileset, in tree order
  std::vector<TilesetBroken> broken;     ///< keep_going only: what could not be read (nothing of it is in the lists above)
};

/// True when `path` looks like a tileset JSON (a .json file whose object has "asset" and "root").
bool is_tileset(const std::string& path);

/// Reads a tileset and its external tilesets (recursively). Throws TilesetError naming the file
/// and its parent tileset for a missing or unreadable tileset or content, a URI outside the entry
/// tileset's folder, implicit tiling, or an external tileset cycle. With keep_going, a missing
/// content and an external tileset that cannot be read (any of those errors inside it) are listed
/// in `broken` instead (with the error they would throw), and the rest of the tree is read; errors
/// of the entry tileset itself still throw.
Tileset read_tileset(const std::string& path, bool keep_going = false);

/// A Batched 3D Model: header tables kept as bytes, the GLB separate.
struct B3dm {
  std::string feature_table_json, feature_table_binary, batch_table_json, batch_table_binary;
  std::vector<uint8_t> glb;
};
/// Parses a b3dm (version 1, current header). Throws TilesetError naming `where` on a bad magic,
/// version, legacy header or lengths past the end.
B3dm parse_b3dm(const std::vector<uint8_t>& bytes, const std::string& where);
/// The b3dm bytes of `b` (tables unchanged, GLB padded to 8 bytes as the specification asks).
std::string write_b3dm(const B3dm& b);

/// One model of a tileset: the contents that share an atlas (io/gltf.h gltf_shared_image_groups),
/// so they must be processed together (one task of `texdefrag batch`).
struct TilesetModel {
  std::vector<std::string> contents;  ///< relative to the entry tileset's folder ('/'), tree order
  std::vector<std::string> files;     ///< what the model reads: its content files, then the image files they name
  std::string parent;                 ///< the tileset JSON naming the first content
};

/// A tileset split into models: every glTF/GLB/b3dm content in exactly one model, in tree order of
/// their first content; `copies`: other contents (pnts, i3dm, cmpt), relative names, passed through.
struct TilesetPlan {
  Tileset tileset;
  std::vector<TilesetModel> models;
  std::vector<std::string> copies;
};

/// Reads the tileset (read_tileset) and groups its contents into models. Reads only each
/// content's JSON; a content that cannot be read (truncated GLB, bad b3dm header) is a model of
/// its own, whose run then fails naming it, so one broken tile does not stop the others. Throws
/// TilesetError naming the file (and the tileset naming it) for a broken tileset tree
/// (read_tileset), unless keep_going: then missing contents and unreadable external tilesets are
/// in plan.tileset.broken and the models are those of the rest of the tree.
TilesetPlan plan_tileset(const std::string& path, bool keep_going = false);

struct TilesetRunOptions {
  std::string tileset;     ///< entry tileset JSON
  std::string output_dir;  ///< must not be the tileset's folder
  ProgressFn progress;
  /// Empty: the whole tileset. Else only the models holding these contents (relative names as
  /// TilesetPlan gives them); each must be a whole model (contents sharing an atlas are named
  /// together), else TilesetError. Only those models' files and reports are written: no tileset
  /// JSON, no copied content, no summary file (finish_tileset writes them once every model is
  /// done); the returned summary holds each model's run report under "reports".
  std::vector<std::string> contents;
};

/// Runs the pipeline on every content of every tile (every level), each group of contents sharing
/// an atlas as one model, and writes the same layout under output_dir: tileset JSONs (copied, or
/// with 3DTILES_content_gltf's extension lists updated when KTX2 or Draco no longer occur), every
/// content under its name, pages beside them, one run report per model
/// (<first content>.report.json) and a summary (<tileset stem>.summary.json, returned). Contents
/// of other kinds (pnts, i3dm, cmpt) are copied unchanged and listed in the summary. Every file
/// appears at once (one OutputSet); any error leaves nothing.
nlohmann::json run_tileset(const PipelineConfig& config, const TilesetRunOptions& options);

/// The rest of a tileset output whose models were run one by one (TilesetRunOptions::contents,
/// `texdefrag batch`): checks every glTF/b3dm content's output exists in output_dir (else
/// TilesetError naming the missing file and the tileset naming its content), copies the other
/// contents and writes every tileset JSON (as run_tileset does: 3DTILES_content_gltf lists drop
/// KHR_texture_basisu / KHR_draco_mesh_compression when no output content uses them any more),
/// all through one OutputSet. Returns the relative names written.
std::vector<std::string> finish_tileset(const std::string& tileset, const std::string& output_dir);

/// Structural check of a tileset as the 3D Tiles specification states it: every content URI
/// exists, and every content's positions (glTF node transforms, b3dm RTC_CENTER, the y-up to z-up
/// rotation, the tile transforms) lie inside the tile's bounding volume (box, sphere or region) and
/// its content bounding volume, within `tolerance` (relative to the volume's size). Returns the
/// problems found (empty: the tileset passes).
std::vector<std::string> check_tileset(const std::string& path, double tolerance = 1e-4);

/// Differences between two tilesets' trees (tile by tile: bounding volumes, transforms, geometric
/// errors, refine, content URIs, extras, children), across external tilesets. Empty when equal.
std::vector<std::string> compare_tilesets(const std::string& a, const std::string& b);

}  // namespace texdefrag
