// Private data of the glTF reader and writer (framework/src/io/gltf_*.cpp).
#pragma once

#include "texdefrag/io/gltf.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace texdefrag::gltf_detail {

using ojson = nlohmann::ordered_json;

/// glTF component type codes.
enum : int { kByte = 5120, kUByte = 5121, kShort = 5122, kUShort = 5123, kUInt = 5125, kFloat = 5126 };

/// Bytes per component of a glTF component type, 0 when unknown.
size_t component_size(int component_type);
/// Components of an accessor type ("SCALAR" 1 ... "MAT4" 16), 0 when unknown.
int type_components(const std::string& type);
/// The accessor type name for a number of components of a vertex attribute (1 -> SCALAR, 2 -> VEC2 ...).
std::string components_type(int components);

/// One vertex attribute of a primitive, tightly packed (count * elem_size bytes), in the
/// accessor's own component type: copying its elements keeps every value byte for byte.
struct RawAttribute {
  int component_type = kFloat;
  int components = 0;        ///< 1..16
  bool normalized = false;
  size_t count = 0;
  std::vector<uint8_t> data;
  int accessor = -1;         ///< input accessor index
  bool had_min_max = false;  ///< the input accessor declared min/max
  size_t elem_size() const { return component_size(component_type) * static_cast<size_t>(components); }
  /// Component c of element i as a double (normalised integers mapped to [0,1] or [-1,1]).
  double value(size_t i, int c) const;
};

using AttributeList = std::vector<std::pair<std::string, RawAttribute>>;

/// Quantisation of a Draco-decoded attribute (origin, range, bits), when it was quantised.
struct DracoQuantization {
  bool valid = false;
  int bits = 0;
  std::vector<float> origin;
  float range = 0;
};

/// A triangle primitive (mode 4, 5 or 6) of one document, decoded.
struct Primitive {
  int mesh = 0, prim = 0;
  int mode = 4;
  std::vector<uint32_t> tri;   ///< 3 vertex indices per triangle, after triangulation
  size_t vertex_count = 0;
  AttributeList attributes;    ///< in the JSON's order
  std::vector<AttributeList> targets;
  bool draco = false;
  DracoQuantization position_quantization;
  int material = -1;           ///< glTF material, -1 none
  int texcoord_set = -1;       ///< TEXCOORD_n of the base colour texture, -1 when untextured
  int texture = -1;            ///< glTF texture of the base colour, -1 when untextured
  int page = kNoPage;          ///< page in the model's mesh
  size_t first_face = 0;       ///< index of its first face in the model's mesh
};

/// One parsed file.
struct Document {
  std::string path;       ///< as given
  std::string base_dir;   ///< URIs resolve against it
  bool binary = false;    ///< GLB (else .gltf JSON)
  ojson json;             ///< the original document, key order kept
  std::vector<std::vector<uint8_t>> buffers;  ///< every buffer's bytes (GLB BIN is buffer 0)
  std::vector<Primitive> primitives;          ///< triangle primitives, file order
};

/// Draco decode of one primitive. `attributes` lists (glTF attribute name, Draco unique id,
/// accessor component type, accessor components, normalised); the result has one RawAttribute each.
struct DracoDecoded {
  size_t num_points = 0;
  std::vector<uint32_t> faces;  ///< 3 per face
  AttributeList attributes;
  DracoQuantization position_quantization;
};
struct DracoAttributeRequest {
  std::string name;
  int unique_id = 0;
  int component_type = kFloat;
  int components = 0;
  bool normalized = false;
  int accessor = -1;
};
/// Throws GltfError starting with `where` when the bytes do not decode or an attribute is missing.
DracoDecoded draco_decode(const uint8_t* data, size_t size, const std::vector<DracoAttributeRequest>& attributes,
                          const std::string& where);

/// Draco encode of one primitive part: sequential connectivity (face and vertex order kept).
/// positions_exact: the POSITION quantisation to reuse (Quantized mode), or invalid.
/// Returns the bytes and the Draco unique id of each attribute (same order as `attributes`).
std::vector<uint8_t> draco_encode(const std::vector<uint32_t>& faces, size_t num_points, const AttributeList& attributes,
                                  const GltfWriteOptions& options, const DracoQuantization& position_quantization,
                                  std::vector<int>* unique_ids, const std::string& where);

/// Base64 of bytes (for data URIs) and back. decode throws GltfError with `where` on bad input.
std::string base64_encode(const uint8_t* data, size_t size);
std::vector<uint8_t> base64_decode(const std::string& text, const std::string& where);

/// Percent-decoding of a URI.
std::string url_decode(const std::string& uri);

/// Image kind from the first bytes: "image/jpeg", "image/png", "image/ktx2", "image/webp" or "".
std::string sniff_mime(const uint8_t* data, size_t size);

}  // namespace texdefrag::gltf_detail
