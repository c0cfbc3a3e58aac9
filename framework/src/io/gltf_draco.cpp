// KHR_draco_mesh_compression: decode (always) and encode (output option) through libdraco.
// note: the encoder uses sequential connectivity, never Edgebreaker: Edgebreaker reorders faces and
// points, and texdefrag keeps every face in its input order (extensions such as a BVH over the
// index buffer rely on it).
#include "gltf_internal.h"

#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/mesh/mesh.h>

#include <cstring>

namespace texdefrag::gltf_detail {
namespace {

template <class T>
bool copy_points(const draco::PointCloud& pc, const draco::PointAttribute& att, int comps, std::vector<uint8_t>& out) {
  out.resize(pc.num_points() * sizeof(T) * static_cast<size_t>(comps));
  T values[16] = {};
  for (draco::PointIndex i(0); i < pc.num_points(); ++i) {
    if (!att.ConvertValue<T>(att.mapped_index(i), static_cast<int8_t>(comps), values)) return false;
    std::memcpy(&out[i.value() * sizeof(T) * static_cast<size_t>(comps)], values, sizeof(T) * static_cast<size_t>(comps));
  }
  return true;
}

bool convert_points(const draco::PointCloud& pc, const draco::PointAttribute& att, int ct, int comps, std::vector<uint8_t>& out) {
  switch (ct) {
    case kFloat: return copy_points<float>(pc, att, comps, out);
    case kUInt: return copy_points<uint32_t>(pc, att, comps, out);
    case kUShort: return copy_points<uint16_t>(pc, att, comps, out);
    case kShort: return copy_points<int16_t>(pc, att, comps, out);
    case kUByte: return copy_points<uint8_t>(pc, att, comps, out);
    case kByte: return copy_points<int8_t>(pc, att, comps, out);
    default: return false;
  }
}

draco::DataType draco_type(int ct) {
  switch (ct) {
    case kFloat: return draco::DT_FLOAT32;
    case kUInt: return draco::DT_UINT32;
    case kUShort: return draco::DT_UINT16;
    case kShort: return draco::DT_INT16;
    case kUByte: return draco::DT_UINT8;
    case kByte: return draco::DT_INT8;
    default: return draco::DT_INVALID;
  }
}

draco::GeometryAttribute::Type semantic(const std::string& name) {
  if (name == "POSITION") return draco::GeometryAttribute::POSITION;
  if (name == "NORMAL") return draco::GeometryAttribute::NORMAL;
  if (name.rfind("TEXCOORD_", 0) == 0) return draco::GeometryAttribute::TEX_COORD;
  if (name.rfind("COLOR_", 0) == 0) return draco::GeometryAttribute::COLOR;
  return draco::GeometryAttribute::GENERIC;
}

/// The POSITION quantisation of Draco data, read by decoding once more without the inverse transform.
DracoQuantization position_quantization(const uint8_t* data, size_t size, int unique_id) {
  DracoQuantization q;
  draco::DecoderBuffer buf;
  buf.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder dec;
  dec.SetSkipAttributeTransform(draco::GeometryAttribute::POSITION);
  auto res = dec.DecodeMeshFromBuffer(&buf);
  if (!res.ok()) return q;
  const draco::PointAttribute* att = res.value()->GetAttributeByUniqueId(static_cast<uint32_t>(unique_id));
  if (!att || !att->GetAttributeTransformData()) return q;
  draco::AttributeQuantizationTransform t;
  if (!t.InitFromAttribute(*att)) return q;
  q.valid = true;
  q.bits = t.quantization_bits();
  q.origin = t.min_values();
  q.range = t.range();
  return q;
}

}  // namespace

DracoDecoded draco_decode(const uint8_t* data, size_t size, const std::vector<DracoAttributeRequest>& req,
                          const std::string& where) {
  draco::DecoderBuffer buf;
  buf.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder dec;
  auto res = dec.DecodeMeshFromBuffer(&buf);
  if (!res.ok()) throw GltfError(where + ": Draco data does not decode: " + res.status().error_msg_string());
  const draco::Mesh& mesh = *res.value();
  DracoDecoded out;
  out.num_points = mesh.num_points();
  out.faces.resize(static_cast<size_t>(mesh.num_faces()) * 3);
  for (draco::FaceIndex f(0); f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) out.faces[f.value() * 3 + static_cast<size_t>(k)] = mesh.face(f)[k].value();
  for (const DracoAttributeRequest& r : req) {
    const draco::PointAttribute* att = mesh.GetAttributeByUniqueId(static_cast<uint32_t>(r.unique_id));
    if (!att) throw GltfError(where + ": attribute " + r.name + " (Draco id " + std::to_string(r.unique_id) + ") is not in the Draco data");
    RawAttribute a;
    a.component_type = r.component_type;
    a.components = r.components;
    a.normalized = r.normalized;
    a.count = out.num_points;
    a.accessor = r.accessor;
    if (component_size(a.component_type) == 0 || a.components <= 0 || a.components > 16)
      throw GltfError(where + ": accessor " + std::to_string(r.accessor) + " (" + r.name + ") has an unsupported type");
    if (!convert_points(mesh, *att, r.component_type, a.components, a.data))
      throw GltfError(where + ": Draco attribute " + r.name + " does not convert to its accessor's type");
    if (r.name == "POSITION") out.position_quantization = position_quantization(data, size, r.unique_id);
    out.attributes.emplace_back(r.name, std::move(a));
  }
  return out;
}

std::vector<uint8_t> draco_encode(const std::vector<uint32_t>& faces, size_t num_points, const AttributeList& attributes,
                                  const GltfWriteOptions& options, const DracoQuantization& pq, std::vector<int>* unique_ids,
                                  const std::string& where) {
  draco::Mesh mesh;
  mesh.set_num_points(static_cast<uint32_t>(num_points));
  for (size_t f = 0; f + 2 < faces.size(); f += 3)
    mesh.AddFace({draco::PointIndex(faces[f]), draco::PointIndex(faces[f + 1]), draco::PointIndex(faces[f + 2])});
  std::vector<int> att_ids;
  for (const auto& [name, a] : attributes) {
    draco::GeometryAttribute ga;
    const draco::DataType dt = draco_type(a.component_type);
    ga.Init(semantic(name), nullptr, static_cast<uint8_t>(a.components), dt, a.normalized,
            static_cast<int64_t>(a.elem_size()), 0);
    const int id = mesh.AddAttribute(ga, true, static_cast<uint32_t>(num_points));
    if (id < 0) throw GltfError(where + ": Draco refused attribute " + name);
    draco::PointAttribute* pa = mesh.attribute(id);
    for (size_t i = 0; i < num_points; ++i)
      pa->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), &a.data[i * a.elem_size()]);
    att_ids.push_back(id);
    unique_ids->push_back(static_cast<int>(pa->unique_id()));
  }
  draco::ExpertEncoder enc(mesh);
  enc.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  enc.SetSpeedOptions(5, 5);
  if (options.draco == DracoOutput::Quantized) {
    for (size_t i = 0; i < attributes.size(); ++i) {
      const auto& [name, a] = attributes[i];
      if (a.component_type != kFloat) continue;  // integer attributes are stored as they are
      const auto sem = semantic(name);
      if (sem == draco::GeometryAttribute::POSITION) {
        if (pq.valid && static_cast<int>(pq.origin.size()) == a.components)
          enc.SetAttributeExplicitQuantization(att_ids[i], pq.bits, a.components, pq.origin.data(), pq.range);
        else
          enc.SetAttributeQuantization(att_ids[i], options.draco_position_bits);
      } else if (sem == draco::GeometryAttribute::TEX_COORD) {
        enc.SetAttributeQuantization(att_ids[i], options.draco_texcoord_bits);
      } else {
        enc.SetAttributeQuantization(att_ids[i], options.draco_generic_bits);
      }
    }
  }
  draco::EncoderBuffer out;
  const draco::Status st = enc.EncodeToBuffer(&out);
  if (!st.ok()) throw GltfError(where + ": Draco encoding failed: " + st.error_msg_string());
  return std::vector<uint8_t>(out.data(), out.data() + out.size());
}

}  // namespace texdefrag::gltf_detail
