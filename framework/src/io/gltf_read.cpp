// glTF 2.0 / GLB reader: tinygltf parses and loads buffers; Draco primitives are decoded here;
// every triangle primitive becomes faces of one TexturedMesh (docs/io.md, "glTF").
#include "gltf_internal.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/measure_transform.h"

#include <tiny_gltf.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <unistd.h>

namespace fs = std::filesystem;

namespace texdefrag {
namespace gltf_detail {

size_t component_size(int ct) {
  switch (ct) {
    case kByte: case kUByte: return 1;
    case kShort: case kUShort: return 2;
    case kUInt: case kFloat: return 4;
    default: return 0;
  }
}

int type_components(const std::string& t) {
  if (t == "SCALAR") return 1;
  if (t == "VEC2") return 2;
  if (t == "VEC3") return 3;
  if (t == "VEC4" || t == "MAT2") return 4;
  if (t == "MAT3") return 9;
  if (t == "MAT4") return 16;
  return 0;
}

std::string components_type(int n) {
  switch (n) {
    case 1: return "SCALAR";
    case 2: return "VEC2";
    case 3: return "VEC3";
    case 4: return "VEC4";
    case 9: return "MAT3";
    case 16: return "MAT4";
    default: return "";
  }
}

double RawAttribute::value(size_t i, int c) const {
  const uint8_t* p = data.data() + i * elem_size() + static_cast<size_t>(c) * component_size(component_type);
  switch (component_type) {
    case kFloat: { float f; std::memcpy(&f, p, 4); return f; }
    case kUInt: { uint32_t v; std::memcpy(&v, p, 4); return v; }
    case kUShort: { uint16_t v; std::memcpy(&v, p, 2); return normalized ? v / 65535.0 : v; }
    case kShort: { int16_t v; std::memcpy(&v, p, 2); return normalized ? std::max(v / 32767.0, -1.0) : v; }
    case kUByte: return normalized ? *p / 255.0 : *p;
    case kByte: { const auto v = static_cast<int8_t>(*p); return normalized ? std::max(v / 127.0, -1.0) : v; }
    default: return 0;
  }
}

std::string sniff_mime(const uint8_t* d, size_t n) {
  if (n >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF) return "image/jpeg";
  if (n >= 8 && std::memcmp(d, "\x89PNG\r\n\x1a\n", 8) == 0) return "image/png";
  if (n >= 12 && std::memcmp(d, "\xABKTX 20\xBB\r\n\x1a\n", 12) == 0) return "image/ktx2";
  if (n >= 12 && std::memcmp(d, "RIFF", 4) == 0 && std::memcmp(d + 8, "WEBP", 4) == 0) return "image/webp";
  return "";
}

namespace {
const char kB64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
}

std::string base64_encode(const uint8_t* d, size_t n) {
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  for (size_t i = 0; i < n; i += 3) {
    const uint32_t v = (uint32_t(d[i]) << 16) | (i + 1 < n ? uint32_t(d[i + 1]) << 8 : 0u) | (i + 2 < n ? d[i + 2] : 0u);
    out += kB64[(v >> 18) & 63];
    out += kB64[(v >> 12) & 63];
    out += i + 1 < n ? kB64[(v >> 6) & 63] : '=';
    out += i + 2 < n ? kB64[v & 63] : '=';
  }
  return out;
}

std::vector<uint8_t> base64_decode(const std::string& s, const std::string& where) {
  std::vector<uint8_t> out;
  uint32_t acc = 0;
  int bits = 0;
  for (char ch : s) {
    if (ch == '=') break;
    const char* p = std::strchr(kB64, ch);
    if (!p || ch == 0) throw GltfError(where + ": invalid base64 character in data URI");
    acc = (acc << 6) | static_cast<uint32_t>(p - kB64);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<uint8_t>((acc >> bits) & 0xFF));
    }
  }
  return out;
}

std::string url_decode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

}  // namespace gltf_detail

using namespace gltf_detail;

namespace {

std::vector<uint8_t> read_file_bytes(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw GltfError(path + ": cannot open " + what);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

uint32_t le32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

/// Checks the GLB container and returns the JSON chunk text.
std::string check_glb(const std::vector<uint8_t>& b, const std::string& where) {
  if (b.size() < 20) throw GltfError(where + ": GLB of " + std::to_string(b.size()) + " bytes is shorter than its 20-byte header");
  const uint32_t version = le32(&b[4]), length = le32(&b[8]);
  if (version != 2) throw GltfError(where + ": GLB version " + std::to_string(version) + " (expected 2)");
  if (length != b.size())
    throw GltfError(where + ": GLB header says " + std::to_string(length) + " bytes, the data has " + std::to_string(b.size()) +
                    (length > b.size() ? " (truncated)" : ""));
  const uint32_t json_len = le32(&b[12]), json_type = le32(&b[16]);
  if (json_type != 0x4E4F534Au) throw GltfError(where + ": first GLB chunk is not JSON");
  if (uint64_t(json_len) + 20 > b.size())
    throw GltfError(where + ": JSON chunk of " + std::to_string(json_len) + " bytes runs past the end of the data (" +
                    std::to_string(b.size()) + " bytes)");
  size_t pos = 20 + json_len;
  if (pos + 8 <= b.size()) {
    const uint32_t bin_len = le32(&b[pos]), bin_type = le32(&b[pos + 4]);
    if (bin_type != 0x004E4942u) throw GltfError(where + ": second GLB chunk is not BIN");
    if (uint64_t(bin_len) + pos + 8 > b.size())
      throw GltfError(where + ": BIN chunk of " + std::to_string(bin_len) + " bytes runs past the end of the data (" +
                      std::to_string(b.size()) + " bytes)");
  } else if (pos != b.size()) {
    throw GltfError(where + ": " + std::to_string(b.size() - pos) + " stray bytes after the JSON chunk");
  }
  return std::string(reinterpret_cast<const char*>(&b[20]), json_len);
}

/// The JSON tinygltf is given: Draco primitives without their "indices". Returns false (and leaves
/// `text` alone) when there are none.
bool strip_draco_indices(const ojson& doc, std::string* text) {
  ojson j = doc;
  bool changed = false;
  if (j.contains("meshes") && j["meshes"].is_array())
    for (auto& mesh : j["meshes"])
      if (mesh.is_object() && mesh.contains("primitives") && mesh["primitives"].is_array())
        for (auto& p : mesh["primitives"])
          if (p.is_object() && p.contains("extensions") && p["extensions"].is_object() &&
              p["extensions"].contains("KHR_draco_mesh_compression") && p.contains("indices")) {
            p.erase("indices");
            changed = true;
          }
  if (changed) *text = j.dump();
  return changed;
}

/// A GLB with another JSON chunk and the same BIN chunk.
std::vector<uint8_t> replace_glb_json(const std::vector<uint8_t>& glb, std::string json) {
  while (json.size() % 4) json += ' ';
  const size_t bin_at = 20 + le32(&glb[12]);
  std::vector<uint8_t> out(glb.begin(), glb.begin() + 12);
  auto put32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xFF));
  };
  put32(static_cast<uint32_t>(json.size()));
  put32(0x4E4F534Au);
  out.insert(out.end(), json.begin(), json.end());
  out.insert(out.end(), glb.begin() + static_cast<std::ptrdiff_t>(bin_at), glb.end());
  const uint32_t total = static_cast<uint32_t>(out.size());
  for (int i = 0; i < 4; ++i) out[8 + static_cast<size_t>(i)] = static_cast<uint8_t>((total >> (8 * i)) & 0xFF);
  return out;
}

// note: tinygltf must not decode images (memory, and it cannot decode KTX2): this loader keeps
// nothing; the reader takes image bytes from files and buffer views itself.
bool no_image_decode(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

std::string prim_name(const Document& d, int mesh, int prim) {
  return d.path + ": mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
}

/// Copies an accessor's elements tightly packed, checking every range.
RawAttribute read_accessor(const tinygltf::Model& m, const Document& d, int index, const std::string& what) {
  const std::string where = d.path + ": accessor " + std::to_string(index) + " (" + what + ")";
  if (index < 0 || static_cast<size_t>(index) >= m.accessors.size())
    throw GltfError(d.path + ": " + what + " names accessor " + std::to_string(index) + " of " + std::to_string(m.accessors.size()));
  const tinygltf::Accessor& a = m.accessors[static_cast<size_t>(index)];
  RawAttribute r;
  r.accessor = index;
  r.component_type = a.componentType;
  r.components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
  r.normalized = a.normalized;
  r.count = a.count;
  r.had_min_max = !a.minValues.empty() && !a.maxValues.empty();
  if (component_size(r.component_type) == 0 || r.components <= 0)
    throw GltfError(where + ": unsupported componentType " + std::to_string(a.componentType));
  if (a.sparse.isSparse) throw GltfError(where + ": sparse accessors are not supported in triangle primitives");
  if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= m.bufferViews.size())
    throw GltfError(where + ": bufferView " + std::to_string(a.bufferView) + " missing or out of range (" +
                    std::to_string(m.bufferViews.size()) + " buffer views)");
  const tinygltf::BufferView& v = m.bufferViews[static_cast<size_t>(a.bufferView)];
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= d.buffers.size())
    throw GltfError(where + ": bufferView " + std::to_string(a.bufferView) + " names buffer " + std::to_string(v.buffer) + " of " +
                    std::to_string(d.buffers.size()));
  if (v.extensions.count("EXT_meshopt_compression"))
    throw GltfError(where + ": EXT_meshopt_compression data is not supported (decompress the file first)");
  const std::vector<uint8_t>& buf = d.buffers[static_cast<size_t>(v.buffer)];
  if (uint64_t(v.byteOffset) + v.byteLength > buf.size())
    throw GltfError(where + ": bufferView " + std::to_string(a.bufferView) + " [" + std::to_string(v.byteOffset) + ", +" +
                    std::to_string(v.byteLength) + ") runs past its buffer of " + std::to_string(buf.size()) + " bytes");
  const size_t es = r.elem_size();
  const size_t stride = v.byteStride ? v.byteStride : es;
  if (r.count > 0 && uint64_t(a.byteOffset) + uint64_t(stride) * (r.count - 1) + es > v.byteLength)
    throw GltfError(where + ": " + std::to_string(r.count) + " elements of " + std::to_string(es) + " bytes (stride " +
                    std::to_string(stride) + ") from offset " + std::to_string(a.byteOffset) + " run past bufferView " +
                    std::to_string(a.bufferView) + " of " + std::to_string(v.byteLength) + " bytes");
  r.data.resize(r.count * es);
  const uint8_t* src = buf.data() + v.byteOffset + a.byteOffset;
  for (size_t i = 0; i < r.count; ++i) std::memcpy(&r.data[i * es], src + i * stride, es);
  return r;
}

/// Triangle list of a primitive from its index list (or 0..n-1) and mode.
std::vector<uint32_t> triangulate(const std::vector<uint32_t>& idx, int mode, const std::string& where) {
  std::vector<uint32_t> t;
  const size_t n = idx.size();
  if (mode == 4) {
    if (n % 3) throw GltfError(where + ": TRIANGLES with " + std::to_string(n) + " indices (not a multiple of 3)");
    return idx;
  }
  if (n < 3) return t;
  t.reserve((n - 2) * 3);
  for (size_t i = 0; i + 2 < n; ++i) {
    if (mode == 5) {  // glTF 2.0 3.7.2.1: {v_i, v_{i+(1+i%2)}, v_{i+(2-i%2)}}
      t.insert(t.end(), {idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]});
    } else {  // fan: {v_{i+1}, v_{i+2}, v_0}
      t.insert(t.end(), {idx[i + 1], idx[i + 2], idx[0]});
    }
  }
  return t;
}

/// Names of textures (other than the base colour) a material samples with texture set `set`.
std::vector<std::string> other_textures_on_set(const ojson& mat, int set) {
  std::vector<std::string> out;
  std::function<void(const ojson&, const std::string&)> walk = [&](const ojson& j, const std::string& path) {
    if (!j.is_object()) return;
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string key = it.key();
      const std::string p = path.empty() ? key : path + "." + key;
      if (p == "pbrMetallicRoughness.baseColorTexture") continue;
      const bool is_tex = key.size() > 7 && key.compare(key.size() - 7, 7, "Texture") == 0 && it->is_object() && it->contains("index");
      if (is_tex) {
        const int tc = it->value("texCoord", 0);
        if (tc == set) out.push_back(p);
      } else if (it->is_object()) {
        walk(*it, p);
      }
    }
  };
  walk(mat, "");
  return out;
}

/// One page image source resolved for a texture.
struct ImageRef {
  std::string key;       ///< identity: canonical file path, or "<doc>#image<N>"
  GltfPageSource src;
};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string file_head_mime(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  uint8_t head[16] = {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  return sniff_mime(head, static_cast<size_t>(in.gcount()));
}

/// Resolves image `img` of document `d`: a JPEG/PNG file or embedded bytes, else its kind.
/// Returns false (with `kind` set) when it is not JPEG/PNG.
bool resolve_image(const Document& d, const tinygltf::Model& m, int img, ImageRef* out, std::string* kind) {
  const std::string label = d.path + " image " + std::to_string(img);
  if (img < 0 || static_cast<size_t>(img) >= m.images.size())
    throw GltfError(d.path + ": image " + std::to_string(img) + " out of range (" + std::to_string(m.images.size()) + " images)");
  const ojson& ij = d.json["images"][static_cast<size_t>(img)];
  out->src.label = label;
  if (ij.contains("uri")) {
    const std::string uri = ij["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0) {
      const size_t comma = uri.find(',');
      if (comma == std::string::npos || uri.find(";base64") > comma)
        throw GltfError(label + ": data URI is not base64");
      out->src.embedded = base64_decode(uri.substr(comma + 1), label);
      out->key = d.path + "#image" + std::to_string(img);
    } else {
      const fs::path p = (fs::path(d.base_dir) / url_decode(uri)).lexically_normal();
      std::error_code ec;
      if (!fs::is_regular_file(p, ec))
        throw GltfError(label + ": image '" + uri + "' not found (looked for " + p.string() + ")");
      out->src.image_file = p.string();
      out->key = fs::weakly_canonical(p, ec).string();
      *kind = file_head_mime(p.string());
      out->src.mime = *kind;
      return *kind == "image/jpeg" || *kind == "image/png";
    }
  } else {
    const int bv = ij.value("bufferView", -1);
    if (bv < 0 || static_cast<size_t>(bv) >= m.bufferViews.size())
      throw GltfError(label + ": neither a uri nor a valid bufferView (" + std::to_string(bv) + ")");
    const tinygltf::BufferView& v = m.bufferViews[static_cast<size_t>(bv)];
    const auto& buf = d.buffers.at(static_cast<size_t>(v.buffer));
    if (uint64_t(v.byteOffset) + v.byteLength > buf.size())
      throw GltfError(label + ": bufferView " + std::to_string(bv) + " runs past its buffer");
    out->src.embedded.assign(buf.begin() + static_cast<std::ptrdiff_t>(v.byteOffset),
                             buf.begin() + static_cast<std::ptrdiff_t>(v.byteOffset + v.byteLength));
    out->key = d.path + "#image" + std::to_string(img);
  }
  *kind = sniff_mime(out->src.embedded.data(), out->src.embedded.size());
  out->src.mime = *kind;
  return *kind == "image/jpeg" || *kind == "image/png";
}

/// A JPEG/PNG file standing in for a KTX2 image: the image's name naming a file beside the
/// document, or the URI with a .jpg/.jpeg/.png extension. Empty when there is none.
std::string ktx2_fallback(const Document& d, const ojson& ij, std::vector<std::string>* looked) {
  std::vector<fs::path> candidates;
  const std::string name = ij.value("name", std::string());
  const std::string ext = lower(fs::path(name).extension().string());
  if (!name.empty() && (ext == ".jpg" || ext == ".jpeg" || ext == ".png")) {
    candidates.push_back(fs::path(d.base_dir) / name);
    if (ij.contains("uri")) candidates.push_back(fs::path(d.base_dir) / fs::path(url_decode(ij["uri"].get<std::string>())).parent_path() / name);
  }
  if (ij.contains("uri") && ij["uri"].get<std::string>().rfind("data:", 0) != 0) {
    const fs::path u = fs::path(d.base_dir) / url_decode(ij["uri"].get<std::string>());
    for (const char* e : {".jpg", ".jpeg", ".png"}) candidates.push_back(fs::path(u).replace_extension(e));
  }
  for (auto c : candidates) {
    c = c.lexically_normal();
    looked->push_back(c.string());
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) {
      const std::string mime = file_head_mime(c.string());
      if (mime == "image/jpeg" || mime == "image/png") return c.string();
    }
  }
  return "";
}

/// The page image of texture `tex`: its core source when JPEG/PNG, else a JPEG/PNG standing in for
/// a KTX2 (or other) image. Throws naming the file when there is none.
ImageRef texture_image(const Document& d, const tinygltf::Model& m, int tex, const std::string& where) {
  if (tex < 0 || static_cast<size_t>(tex) >= m.textures.size())
    throw GltfError(where + ": baseColorTexture names texture " + std::to_string(tex) + " of " + std::to_string(m.textures.size()));
  const ojson& tj = d.json["textures"][static_cast<size_t>(tex)];
  ImageRef ref;
  std::string kind;
  std::vector<int> others;  // images of texture extensions (KHR_texture_basisu, EXT_texture_webp, ...)
  if (tj.contains("extensions"))
    for (const auto& e : tj["extensions"].items())
      if (e.value().is_object() && e.value().contains("source")) others.push_back(e.value()["source"].get<int>());
  if (tj.contains("source")) {
    if (resolve_image(d, m, tj["source"].get<int>(), &ref, &kind)) return ref;
    others.insert(others.begin(), tj["source"].get<int>());
  }
  if (others.empty()) throw GltfError(where + ": texture " + std::to_string(tex) + " has no image");
  std::vector<std::string> looked;
  for (int img : others) {
    const ojson& ij = d.json["images"].at(static_cast<size_t>(img));
    ImageRef probe;
    std::string k;
    if (resolve_image(d, m, img, &probe, &k)) return probe;  // e.g. EXT_texture_webp's fallback order
    const std::string fb = ktx2_fallback(d, ij, &looked);
    if (!fb.empty()) {
      std::error_code ec;
      ref.src = GltfPageSource{};
      ref.src.image_file = fb;
      ref.src.mime = file_head_mime(fb);
      ref.src.replaces_ktx2 = probe.src.image_file.empty() ? probe.src.label : probe.src.image_file;
      ref.src.label = d.path + " image " + std::to_string(img);
      ref.key = fs::weakly_canonical(fb, ec).string();
      return ref;
    }
    kind = k.empty() ? "an unknown format" : k;
  }
  std::string list;
  for (const auto& l : looked) list += (list.empty() ? "" : ", ") + l;
  throw GltfError(where + ": texture " + std::to_string(tex) + " is " + kind +
                  " only (KHR_texture_basisu/KTX2 cannot be decoded: no Basis transcoder in Debian 12) and no JPEG/PNG source was found" +
                  (list.empty() ? std::string() : " (looked for " + list + ")"));
}

/// decode_primitive's Draco branch: the attributes, vertex count and position quantisation of P
/// from its KHR_draco_mesh_compression data (every attribute must be in it, counts must agree with
/// the accessors); returns the corner indices. Throws GltfError naming `where`.
std::vector<uint32_t> decode_draco_primitive(const tinygltf::Model& m, Document& d, Primitive& P, const ojson& pj,
                                             const tinygltf::Primitive& tp, const std::string& where) {
  P.draco = true;
  const ojson& ext = pj["extensions"]["KHR_draco_mesh_compression"];
  const int bv = ext.value("bufferView", -1);
  if (bv < 0 || static_cast<size_t>(bv) >= m.bufferViews.size())
    throw GltfError(where + ": KHR_draco_mesh_compression bufferView " + std::to_string(bv) + " out of range");
  const tinygltf::BufferView& v = m.bufferViews[static_cast<size_t>(bv)];
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= d.buffers.size() ||
      uint64_t(v.byteOffset) + v.byteLength > d.buffers[static_cast<size_t>(v.buffer)].size())
    throw GltfError(where + ": KHR_draco_mesh_compression bufferView " + std::to_string(bv) + " runs past its buffer");
  std::vector<DracoAttributeRequest> req;
  for (const auto& [name, acc] : tp.attributes) {
    if (!ext.contains("attributes") || !ext["attributes"].contains(name))
      throw GltfError(where + ": attribute " + name + " is not in the Draco data (uncompressed attributes beside Draco are not supported)");
    if (acc < 0 || static_cast<size_t>(acc) >= m.accessors.size())
      throw GltfError(where + ": attribute " + name + " names accessor " + std::to_string(acc) + " out of range");
    const tinygltf::Accessor& a = m.accessors[static_cast<size_t>(acc)];
    req.push_back({name, ext["attributes"][name].get<int>(), a.componentType,
                   tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type)), a.normalized, acc});
  }
  DracoDecoded dd = draco_decode(d.buffers[static_cast<size_t>(v.buffer)].data() + v.byteOffset, v.byteLength, req, where);
  for (auto& a : dd.attributes) {
    const tinygltf::Accessor& acc = m.accessors[static_cast<size_t>(a.second.accessor)];
    a.second.had_min_max = !acc.minValues.empty() && !acc.maxValues.empty();
    if (acc.count != dd.num_points)
      throw GltfError(where + ": accessor " + std::to_string(a.second.accessor) + " (" + a.first + ") count " +
                      std::to_string(acc.count) + " differs from the Draco data's " + std::to_string(dd.num_points) + " points");
  }
  P.attributes = std::move(dd.attributes);
  P.vertex_count = dd.num_points;
  P.position_quantization = dd.position_quantization;
  const int ind = pj.value("indices", -1);
  if (ind >= 0 && static_cast<size_t>(ind) < m.accessors.size() && m.accessors[static_cast<size_t>(ind)].count != dd.faces.size())
    throw GltfError(where + ": indices accessor count " + std::to_string(m.accessors[static_cast<size_t>(ind)].count) +
                    " differs from the Draco data's " + std::to_string(dd.faces.size()) + " corners");
  if (P.mode != 4) throw GltfError(where + ": Draco data with mode " + std::to_string(P.mode) + " (expected TRIANGLES)");
  if (!tp.targets.empty()) throw GltfError(where + ": morph targets with Draco compression are not supported");
  return std::move(dd.faces);
}

/// decode_primitive's accessor branch: the attributes (in the JSON's order), morph targets and
/// vertex count of P from its accessors; returns the corner indices (0, 1, ... without an indices
/// accessor). Throws GltfError naming `where` on counts that disagree or indices of a bad type.
std::vector<uint32_t> read_primitive_accessors(const tinygltf::Model& m, Document& d, Primitive& P, const ojson& pj,
                                               const tinygltf::Primitive& tp, const std::string& where) {
  // Attributes in the JSON's order (tinygltf's map is sorted).
  for (const auto& it : pj["attributes"].items())
    P.attributes.emplace_back(it.key(), read_accessor(m, d, it.value().get<int>(), it.key() + " of mesh " + std::to_string(P.mesh) +
                                                                                    " primitive " + std::to_string(P.prim)));
  if (pj.contains("targets"))
    for (const auto& t : pj["targets"]) {
      AttributeList tl;
      for (const auto& it : t.items())
        tl.emplace_back(it.key(), read_accessor(m, d, it.value().get<int>(), "morph target " + it.key()));
      P.targets.push_back(std::move(tl));
    }
  P.vertex_count = P.attributes.empty() ? 0 : P.attributes.front().second.count;
  for (const auto& a : P.attributes)
    if (a.second.count != P.vertex_count)
      throw GltfError(where + ": attribute " + a.first + " has " + std::to_string(a.second.count) + " elements, " +
                      P.attributes.front().first + " has " + std::to_string(P.vertex_count));
  for (const auto& tl : P.targets)
    for (const auto& a : tl)
      if (a.second.count != P.vertex_count) throw GltfError(where + ": morph target " + a.first + " count differs from the vertex count");
  std::vector<uint32_t> idx;
  if (tp.indices >= 0) {
    const RawAttribute ia = read_accessor(m, d, tp.indices, "indices of mesh " + std::to_string(P.mesh) + " primitive " + std::to_string(P.prim));
    if (ia.components != 1 || (ia.component_type != kUByte && ia.component_type != kUShort && ia.component_type != kUInt))
      throw GltfError(where + ": indices accessor " + std::to_string(tp.indices) + " is not SCALAR unsigned byte/short/int");
    idx.resize(ia.count);
    for (size_t i = 0; i < ia.count; ++i) idx[i] = static_cast<uint32_t>(ia.value(i, 0));
  } else {
    idx.resize(P.vertex_count);
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<uint32_t>(i);
  }
  return idx;
}

/// Reads the data of one triangle primitive (accessors or Draco).
void decode_primitive(const tinygltf::Model& m, Document& d, Primitive& P, const ojson& pj) {
  const std::string where = prim_name(d, P.mesh, P.prim);
  // note: tinygltf drops a primitive without "attributes" (and a mesh with a bad one) that the
  // JSON lists; reading on would index past its lists (found by fuzz_gltf).
  if (static_cast<size_t>(P.mesh) >= m.meshes.size() || static_cast<size_t>(P.prim) >= m.meshes[static_cast<size_t>(P.mesh)].primitives.size() ||
      !pj.contains("attributes") || !pj["attributes"].is_object())
    throw GltfError(where + ": no \"attributes\" object (required)");
  const tinygltf::Primitive& tp = m.meshes[static_cast<size_t>(P.mesh)].primitives[static_cast<size_t>(P.prim)];
  const std::vector<uint32_t> idx = pj.contains("extensions") && pj["extensions"].contains("KHR_draco_mesh_compression")
                                        ? decode_draco_primitive(m, d, P, pj, tp, where)
                                        : read_primitive_accessors(m, d, P, pj, tp, where);
  for (size_t i = 0; i < idx.size(); ++i)
    if (idx[i] >= P.vertex_count)
      throw GltfError(where + ": index " + std::to_string(idx[i]) + " at position " + std::to_string(i) + " out of range (" +
                      std::to_string(P.vertex_count) + " vertices)");
  P.tri = triangulate(idx, P.mode, where);
}

const RawAttribute* find_attribute(const Primitive& P, const std::string& name) {
  for (const auto& a : P.attributes)
    if (a.first == name) return &a.second;
  return nullptr;
}

/// Loads one document: container checks, tinygltf parse, original JSON kept.
std::pair<Document, tinygltf::Model> load_document(const GltfInput& in) {
  Document d;
  d.path = in.path;
  d.base_dir = !in.base_dir.empty() ? in.base_dir : fs::path(in.path).parent_path().string();
  if (d.base_dir.empty()) d.base_dir = ".";
  const std::vector<uint8_t> bytes = in.bytes.empty() ? read_file_bytes(in.path, "glTF file") : in.bytes;
  const std::string ext = lower(fs::path(in.path).extension().string());
  std::string json_text;
  d.binary = is_glb(bytes);
  if (d.binary) {
    json_text = check_glb(bytes, d.path);
  } else {
    if (ext == ".glb" || ext == ".b3dm" || (!bytes.empty() && bytes[0] != '{' && bytes[0] != ' ' && bytes[0] != '\n' && bytes[0] != '\r' && bytes[0] != '\t' && bytes[0] != 0xEF))
      throw GltfError(d.path + ": not a GLB (bad magic: expected 'glTF') and not glTF JSON");
    json_text.assign(bytes.begin(), bytes.end());
  }
  try {
    d.json = ojson::parse(json_text);
  } catch (const std::exception& e) {
    throw GltfError(d.path + ": glTF JSON: " + e.what());
  }
  if (!d.json.is_object()) throw GltfError(d.path + ": glTF JSON is not an object");
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(no_image_decode, nullptr);
  std::string err, warn;
  // note: Debian's tinygltf 2.7 is built without Draco and rejects a Draco primitive's indices
  // accessor (it has no bufferView until decoded), so tinygltf sees the JSON without them; this
  // reader decodes Draco itself.
  std::vector<uint8_t> glb = bytes;
  if (strip_draco_indices(d.json, &json_text) && d.binary) glb = replace_glb_json(bytes, json_text);
  const bool ok = d.binary ? loader.LoadBinaryFromMemory(&m, &err, &warn, glb.data(), static_cast<unsigned>(glb.size()), d.base_dir)
                           : loader.LoadASCIIFromString(&m, &err, &warn, json_text.data(), static_cast<unsigned>(json_text.size()), d.base_dir);
  if (!ok) {
    while (!err.empty() && err.back() == '\n') err.pop_back();
    throw GltfError(d.path + ": " + (err.empty() ? std::string("tinygltf could not load the file") : err));
  }
  for (const auto& b : m.buffers) d.buffers.push_back(b.data);
  return {std::move(d), std::move(m)};
}

/// The linear part of a node's local matrix: `matrix` (16 numbers, column-major) or R(rotation) *
/// diag(scale) of its TRS (the translation is no part of it). Throws GltfError naming the node.
Mat3 node_linear(const Document& d, const ojson& node, size_t index) {
  const std::string where = d.path + ": node " + std::to_string(index);
  auto numbers = [&](const char* key, size_t n) {
    std::vector<double> v;
    const ojson& a = node[key];
    if (!a.is_array() || a.size() != n) throw GltfError(where + ": '" + key + "' is not an array of " + std::to_string(n) + " numbers");
    for (const auto& x : a) {
      if (!x.is_number() || !std::isfinite(x.get<double>()))
        throw GltfError(where + ": '" + key + "' is not an array of " + std::to_string(n) + " finite numbers");
      v.push_back(x.get<double>());
    }
    return v;
  };
  Mat3 m = Mat3::Identity();
  if (node.contains("matrix")) {
    const std::vector<double> t = numbers("matrix", 16);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = t[static_cast<size_t>(c * 4 + r)];
    return m;
  }
  if (node.contains("rotation")) {
    const std::vector<double> q = numbers("rotation", 4);  // x, y, z, w
    const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
    if (quat.norm() == 0.0) throw GltfError(where + ": 'rotation' is a zero quaternion");
    m = quat.normalized().toRotationMatrix();
  }
  if (node.contains("scale")) {
    const std::vector<double> s = numbers("scale", 3);
    m = m * Eigen::Vector3d(s[0], s[1], s[2]).asDiagonal();
  }
  return m;
}

/// Per glTF mesh of `d`: the stretch (io/measure_transform.h) of outer * the linear part of the
/// mesh's first node's world matrix. Nodes are visited scene by scene (the default scene first,
/// then the others in order), then nodes that no scene reaches, depth first; a mesh no node names
/// gets the stretch of `outer` alone. Throws GltfError naming the file for a node index out of
/// range or a node reached twice on one path (a cycle).
std::vector<Mat3> mesh_stretches(const Document& d, const Mat3& outer) {
  const ojson empty = ojson::array();
  const ojson& nodes = d.json.contains("nodes") ? d.json["nodes"] : empty;
  const size_t n_meshes = d.json.contains("meshes") ? d.json["meshes"].size() : 0;
  std::vector<Mat3> stretch(n_meshes, Mat3::Identity());
  std::vector<uint8_t> assigned(n_meshes, 0), visited(nodes.size(), 0), on_path(nodes.size(), 0);
  std::function<void(const ojson&, const Mat3&, const std::string&)> visit = [&](const ojson& index, const Mat3& parent,
                                                                                  const std::string& from) {
    if (!index.is_number_integer() || index.get<long long>() < 0 || static_cast<size_t>(index.get<long long>()) >= nodes.size())
      throw GltfError(d.path + ": " + from + " names node " + index.dump() + ", out of range (" + std::to_string(nodes.size()) + " nodes)");
    const size_t i = static_cast<size_t>(index.get<long long>());
    if (on_path[i]) throw GltfError(d.path + ": node " + std::to_string(i) + " is its own ancestor (" + from + ")");
    const ojson& node = nodes[i];
    const Mat3 world = parent * node_linear(d, node, i);
    visited[i] = on_path[i] = 1;
    if (node.contains("mesh") && node["mesh"].is_number_integer()) {
      const long long m = node["mesh"].get<long long>();
      if (m >= 0 && static_cast<size_t>(m) < n_meshes && !assigned[static_cast<size_t>(m)]) {
        assigned[static_cast<size_t>(m)] = 1;
        stretch[static_cast<size_t>(m)] = stretch_part(world);
      }
    }
    if (node.contains("children"))
      for (const auto& c : node["children"]) visit(c, world, "children of node " + std::to_string(i));
    on_path[i] = 0;
  };
  const ojson& scenes = d.json.contains("scenes") ? d.json["scenes"] : empty;
  std::vector<size_t> order;
  const long long first = d.json.value("scene", 0LL);
  if (first >= 0 && static_cast<size_t>(first) < scenes.size()) order.push_back(static_cast<size_t>(first));
  for (size_t s = 0; s < scenes.size(); ++s)
    if (order.empty() || s != order.front()) order.push_back(s);
  for (size_t s : order)
    if (scenes[s].contains("nodes"))
      for (const auto& n : scenes[s]["nodes"]) visit(n, outer, "scene " + std::to_string(s));
  std::vector<uint8_t> is_child(nodes.size(), 0);
  for (const auto& node : nodes)
    if (node.contains("children"))
      for (const auto& c : node["children"])
        if (c.is_number_integer() && c.get<long long>() >= 0 && static_cast<size_t>(c.get<long long>()) < nodes.size())
          is_child[static_cast<size_t>(c.get<long long>())] = 1;
  for (size_t i = 0; i < nodes.size(); ++i)
    if (!visited[i] && !is_child[i]) visit(ojson(i), outer, "the node list");
  const Mat3 outer_stretch = stretch_part(outer);
  for (size_t m = 0; m < n_meshes; ++m)
    if (!assigned[m]) stretch[m] = outer_stretch;
  return stretch;
}

/// Adds the faces of one primitive to the model's mesh.
/// stretch: the mesh's node transform stretch; positions are multiplied by it for measuring.
void add_faces(GltfModel& model, int file, Primitive& P, int material, const Mat3& stretch) {
  TexturedMesh& mesh = model.mesh;
  const std::string where = prim_name((*model.documents)[static_cast<size_t>(file)], P.mesh, P.prim);
  const RawAttribute* pos = find_attribute(P, "POSITION");
  if (!pos) throw GltfError(where + ": no POSITION attribute");
  if (pos->components != 3) throw GltfError(where + ": POSITION is not VEC3");
  const size_t v0 = mesh.positions.size();
  for (size_t i = 0; i < P.vertex_count; ++i) {
    const Vec3 p(pos->value(i, 0), pos->value(i, 1), pos->value(i, 2));
    if (!p.allFinite()) throw GltfError(where + ": POSITION of vertex " + std::to_string(i) + " is not finite");
    mesh.positions.push_back(p);
  }
  model.positions_stretched += apply_stretch(mesh.positions, v0, stretch);
  const RawAttribute* tc = nullptr;
  if (P.texcoord_set >= 0) {
    tc = find_attribute(P, "TEXCOORD_" + std::to_string(P.texcoord_set));
    if (!tc) throw GltfError(where + ": material " + std::to_string(P.material) + " samples TEXCOORD_" + std::to_string(P.texcoord_set) + ", which the primitive lacks");
    if (tc->components != 2) throw GltfError(where + ": TEXCOORD_" + std::to_string(P.texcoord_set) + " is not VEC2");
  }
  const size_t t0 = mesh.texcoords.size();
  if (tc)
    for (size_t i = 0; i < P.vertex_count; ++i) {
      const Vec2 t(tc->value(i, 0), 1.0 - tc->value(i, 1));
      if (!t.allFinite()) throw GltfError(where + ": TEXCOORD_" + std::to_string(P.texcoord_set) + " of vertex " + std::to_string(i) + " is not finite");
      mesh.texcoords.push_back(t);
    }
  P.first_face = mesh.faces.size();
  const size_t nt = P.tri.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    Face f;
    for (int k = 0; k < 3; ++k) {
      const uint32_t vi = P.tri[t * 3 + static_cast<size_t>(k)];
      f.v[static_cast<size_t>(k)] = static_cast<int>(v0 + vi);
      if (tc) f.vt[static_cast<size_t>(k)] = static_cast<int>(t0 + vi);
    }
    f.material = material;
    f.page = tc ? P.page : kNoPage;
    mesh.faces.push_back(f);
    model.face_source.push_back({file, P.mesh, P.prim, static_cast<int>(t)});
  }
}

}  // namespace

std::vector<std::vector<size_t>> gltf_shared_image_groups(const std::vector<GltfInput>& inputs,
                                                          std::vector<std::vector<std::string>>* image_files,
                                                          std::vector<std::string>* unreadable) {
  if (image_files) image_files->assign(inputs.size(), {});
  std::vector<size_t> parent(inputs.size());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  std::function<size_t(size_t)> find = [&](size_t i) { return parent[i] == i ? i : parent[i] = find(parent[i]); };
  std::map<std::string, size_t> owner;  // image path -> first document naming it
  for (size_t i = 0; i < inputs.size(); ++i) {
    const GltfInput& in = inputs[i];
    ojson j;
    try {
      const std::vector<uint8_t> bytes = in.bytes.empty() ? read_file_bytes(in.path, "glTF file") : in.bytes;
      try {
        j = ojson::parse(is_glb(bytes) ? check_glb(bytes, in.path) : std::string(bytes.begin(), bytes.end()));
      } catch (const nlohmann::json::exception& e) {
        throw GltfError(in.path + ": glTF JSON: " + e.what());
      }
    } catch (const std::exception& e) {
      if (!unreadable) throw;
      unreadable->push_back(e.what());
      continue;  // a group of its own
    }
    const fs::path base = !in.base_dir.empty() ? fs::path(in.base_dir) : fs::path(in.path).parent_path();
    if (!j.is_object() || !j.contains("images") || !j["images"].is_array()) continue;
    for (const auto& img : j["images"]) {
      if (!img.is_object() || !img.contains("uri") || !img["uri"].is_string()) continue;
      const std::string uri = img["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      const std::string key = (base / url_decode(uri)).lexically_normal().string();
      auto it = owner.emplace(key, i).first;
      parent[find(i)] = find(it->second);
      if (image_files) {
        std::vector<fs::path> candidates = {key};
        if (img.contains("name") && img["name"].is_string()) candidates.push_back(base / img["name"].get<std::string>());
        for (const char* e : {".jpg", ".jpeg", ".png"}) candidates.push_back(fs::path(key).replace_extension(e));
        std::error_code ec;
        for (const fs::path& c : candidates) {
          const std::string f = c.lexically_normal().string();
          auto& list = (*image_files)[i];
          if (fs::is_regular_file(f, ec) && std::find(list.begin(), list.end(), f) == list.end()) list.push_back(f);
        }
      }
    }
  }
  std::map<size_t, size_t> group_of_root;
  std::vector<std::vector<size_t>> groups;
  for (size_t i = 0; i < inputs.size(); ++i) {
    auto it = group_of_root.emplace(find(i), groups.size()).first;
    if (it->second == groups.size()) groups.emplace_back();
    groups[it->second].push_back(i);
  }
  return groups;
}

bool is_glb(const std::vector<uint8_t>& b) { return b.size() >= 4 && std::memcmp(b.data(), "glTF", 4) == 0; }

GltfModel read_gltf(const std::string& path, const GltfReadOptions& options) {
  GltfInput in;
  in.path = path;
  return read_gltf(std::vector<GltfInput>{in}, options);
}

namespace {

/// What read_inputs keeps across documents: pages by image key, mesh materials by (file, glTF
/// material), and the primitive counts of GltfModel::stats.
struct ReadState {
  std::map<std::string, int> page_of_key;
  std::map<std::pair<int, int>, int> material_of;  // (file, glTF material) -> mesh material
  size_t draco_prims = 0, skipped_prims = 0, triangle_prims = 0, ktx2_replaced = 0;
};

/// The JSON of P's material (nullptr without one); sets P.texture and P.texcoord_set from its
/// baseColorTexture. Throws GltfError naming `where` for a material out of range or a
/// KHR_texture_transform on the base colour.
const ojson* primitive_material(Document& d, Primitive& P, const std::string& where) {
  if (P.material < 0) return nullptr;
  if (!d.json.contains("materials") || static_cast<size_t>(P.material) >= d.json["materials"].size())
    throw GltfError(where + ": material " + std::to_string(P.material) + " out of range");
  const ojson* mat = &d.json["materials"][static_cast<size_t>(P.material)];
  const ojson* pbr = mat->contains("pbrMetallicRoughness") ? &(*mat)["pbrMetallicRoughness"] : nullptr;
  if (pbr && pbr->contains("baseColorTexture")) {
    const ojson& bct = (*pbr)["baseColorTexture"];
    P.texture = bct.value("index", -1);
    P.texcoord_set = bct.value("texCoord", 0);
    if (bct.contains("extensions") && bct["extensions"].contains("KHR_texture_transform"))
      throw GltfError(where + ": material " + std::to_string(P.material) + " baseColorTexture uses KHR_texture_transform (not supported)");
  }
  return mat;
}

/// The page of textured primitive P (its material's JSON `mat`): the page of its image, added to
/// model (page and GltfPageSource) the first time an image key is seen.
int primitive_page(GltfModel& model, const Document& d, const tinygltf::Model& m, const Primitive& P, const ojson& mat,
                   const std::string& where, ReadState& st) {
  ImageRef ref = texture_image(d, m, P.texture, where);
  auto it = st.page_of_key.find(ref.key);
  if (it == st.page_of_key.end()) {
    Page pg;
    pg.material = mat.value("name", "material_" + std::to_string(P.material));
    pg.image_path = ref.src.image_file.empty() ? ref.src.label : ref.src.image_file;
    st.ktx2_replaced += !ref.src.replaces_ktx2.empty();
    it = st.page_of_key.emplace(ref.key, static_cast<int>(model.mesh.pages.size())).first;
    model.mesh.pages.push_back(pg);
    model.page_source.push_back(ref.src);
  }
  return it->second;
}

/// The mesh material of P (glTF material P.material of file `fi`, JSON `mat`), added to
/// model.mesh.materials the first time; kNoIndex without a material.
int primitive_mesh_material(GltfModel& model, size_t fi, const Primitive& P, const ojson* mat, ReadState& st) {
  if (P.material < 0) return kNoIndex;
  auto mit = st.material_of.find({static_cast<int>(fi), P.material});
  if (mit == st.material_of.end()) {
    Material mm;
    mm.name = mat->value("name", "material_" + std::to_string(P.material));
    mit = st.material_of.emplace(std::make_pair(static_cast<int>(fi), P.material), static_cast<int>(model.mesh.materials.size())).first;
    model.mesh.materials.push_back(mm);
  }
  return mit->second;
}

/// Reads primitive `pi` of mesh `mi` of document `d` (file `fi`, JSON `pj`) into `model`: a
/// triangle primitive's faces (positions through `stretch`), page and material; a point or line
/// primitive is counted and left to the writer untouched (an error when textured).
void read_primitive(GltfModel& model, Document& d, const tinygltf::Model& m, size_t fi, size_t mi, size_t pi,
                    const ojson& pj, const Mat3& stretch, ReadState& st) {
  Primitive P;
  P.mesh = static_cast<int>(mi);
  P.prim = static_cast<int>(pi);
  P.mode = pj.value("mode", 4);
  P.material = pj.value("material", -1);
  const std::string where = prim_name(d, P.mesh, P.prim);
  const ojson* mat = primitive_material(d, P, where);
  if (P.mode < 0 || P.mode > 6) throw GltfError(where + ": unknown primitive mode " + std::to_string(P.mode));
  if (P.mode < 4) {
    static const char* kModes[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
    if (P.texture >= 0)
      throw GltfError(where + ": mode " + kModes[P.mode] + " with a textured material (material " + std::to_string(P.material) +
                      ") is not supported: texdefrag defragments triangle textures only");
    ++st.skipped_prims;  // kept untouched by the writer
    return;
  }
  if (P.texture >= 0) {
    const auto others = other_textures_on_set(*mat, P.texcoord_set);
    if (!others.empty())
      throw GltfError(where + ": material " + std::to_string(P.material) + " also samples " + others.front() + " with TEXCOORD_" +
                      std::to_string(P.texcoord_set) + "; texdefrag rewrites those coordinates for the base colour only (not supported)");
  }
  decode_primitive(m, d, P, pj);
  st.draco_prims += P.draco;
  ++st.triangle_prims;
  if (P.texture >= 0) P.page = primitive_page(model, d, m, P, *mat, where, st);
  const int material = primitive_mesh_material(model, fi, P, mat, st);
  add_faces(model, static_cast<int>(fi), P, material, stretch);
  d.primitives.push_back(std::move(P));
}

/// Sets the size of every page of `model`: from its image file's header, else by decoding the
/// embedded image.
void read_page_sizes(GltfModel& model) {
  for (size_t p = 0; p < model.mesh.pages.size(); ++p) {
    Page& pg = model.mesh.pages[p];
    const GltfPageSource& s = model.page_source[p];
    if (!s.image_file.empty()) {
      read_image_size(s.image_file, pg.width, pg.height);
    } else {
      const Image img = read_gltf_page(model, static_cast<int>(p));
      pg.width = img.width;
      pg.height = img.height;
    }
  }
}

/// read_gltf's body; `current` is the input being read.
GltfModel read_inputs(const std::vector<GltfInput>& inputs, const GltfReadOptions& options, size_t& current) {
  GltfModel model;
  auto docs = std::make_shared<std::vector<Document>>();
  model.documents = docs;
  ReadState st;
  for (size_t fi = 0; fi < inputs.size(); ++fi) {
    current = fi;
    auto [doc, m] = load_document(inputs[fi]);
    GltfInput kept = inputs[fi];
    kept.bytes.clear();
    model.inputs.push_back(kept);
    docs->push_back(std::move(doc));
    Document& d = docs->back();
    const std::vector<Mat3> stretches = mesh_stretches(d, inputs[fi].outer_linear);
    const ojson& meshes = d.json.contains("meshes") ? d.json["meshes"] : ojson::array();
    for (size_t mi = 0; mi < meshes.size(); ++mi) {
      const ojson& prims = meshes[mi].value("primitives", ojson::array());
      for (size_t pi = 0; pi < prims.size(); ++pi) read_primitive(model, d, m, fi, mi, pi, prims[pi], stretches[mi], st);
    }
  }
  if (options.read_page_sizes) read_page_sizes(model);
  model.stats = {{"files", inputs.size()},
                 {"triangle_primitives", st.triangle_prims},
                 {"draco_primitives", st.draco_prims},
                 {"untouched_point_line_primitives", st.skipped_prims},
                 {"ktx2_pages_read_from_jpeg_png", st.ktx2_replaced},
                 {"positions_stretched", model.positions_stretched},
                 {"faces", model.mesh.faces.size()},
                 {"pages", model.mesh.pages.size()}};
  return model;
}

}  // namespace

GltfModel read_gltf(const std::vector<GltfInput>& inputs, const GltfReadOptions& options) {
  if (inputs.empty()) throw GltfError("read_gltf: no input");
  size_t current = 0;
  try {
    return read_inputs(inputs, options, current);
  } catch (const nlohmann::json::exception& e) {
    // note: a member of another JSON type than the reader reads ("mode": "4", "uri": {}) makes the
    // JSON library throw; the error names the file like every other (found by fuzz_gltf).
    throw GltfError(inputs[current].path + ": glTF JSON: " + e.what());
  }
}

Image read_gltf_page(const GltfModel& model, int page) {
  const GltfPageSource& s = model.page_source.at(static_cast<size_t>(page));
  if (!s.image_file.empty()) return read_image(s.image_file);
  return decode_image(s.embedded.data(), s.embedded.size(), s.label);  // PNG or JPEG (the reader checked)
}

}  // namespace texdefrag
