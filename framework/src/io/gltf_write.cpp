// glTF 2.0 / GLB writer: edits each input document's JSON and rebuilds its buffers (docs/io.md,
// "glTF"). Only textured triangle primitives, their accessors and buffer views, the base colour
// textures and images, and the materials of those primitives change.
#include "gltf_internal.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <set>

namespace fs = std::filesystem;

namespace texdefrag {

using namespace gltf_detail;

namespace {

/// Extensions whose "source" names an image of a texture.
bool is_image_source_extension(const std::string& name) {
  return name == "KHR_texture_basisu" || name == "EXT_texture_webp" || name == "EXT_texture_avif" || name == "MSFT_texture_dds";
}

std::string ext_of_mime(const std::string& mime) { return mime == "image/png" ? ".png" : ".jpg"; }

/// One output primitive: the faces of one input primitive that landed on one output page.
struct Part {
  int page = 0;
  std::vector<uint32_t> tri;          ///< new vertex indices, 3 per face, input order
  std::vector<uint32_t> src_vertex;   ///< input vertex of each new vertex
  std::vector<int> src_texcoord;      ///< output texcoord (index into out.texcoords) of each new vertex
  AttributeList attributes;
  std::vector<AttributeList> targets;
};

/// Splits a rewritten primitive's faces by output page and builds their vertex data.
std::vector<Part> build_parts(const Primitive& P, const TexturedMesh& out, const std::string& where) {
  std::vector<Part> parts;
  std::map<int, size_t> part_of_page;
  std::vector<std::map<std::pair<uint32_t, int>, uint32_t>> vmap;
  const size_t nt = P.tri.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    const Face& F = out.faces[P.first_face + t];
    if (F.page == kNoPage) throw GltfError(where + ": face " + std::to_string(t) + " has no output page");
    auto it = part_of_page.find(F.page);
    if (it == part_of_page.end()) {
      it = part_of_page.emplace(F.page, parts.size()).first;
      parts.emplace_back();
      parts.back().page = F.page;
      vmap.emplace_back();
    }
    Part& part = parts[it->second];
    auto& vm = vmap[it->second];
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = P.tri[t * 3 + static_cast<size_t>(k)];
      const int vt = F.vt[static_cast<size_t>(k)];
      if (vt < 0 || static_cast<size_t>(vt) >= out.texcoords.size())
        throw GltfError(where + ": face " + std::to_string(t) + " has no output texture coordinate");
      auto ins = vm.emplace(std::make_pair(v, vt), static_cast<uint32_t>(part.src_vertex.size()));
      if (ins.second) {
        part.src_vertex.push_back(v);
        part.src_texcoord.push_back(vt);
      }
      part.tri.push_back(ins.first->second);
    }
  }
  const std::string uv_name = "TEXCOORD_" + std::to_string(P.texcoord_set);
  auto copy_attr = [](const RawAttribute& src, const std::vector<uint32_t>& sv) {
    RawAttribute a = src;
    const size_t es = src.elem_size();
    a.count = sv.size();
    a.data.resize(sv.size() * es);
    for (size_t i = 0; i < sv.size(); ++i) std::memcpy(&a.data[i * es], &src.data[sv[i] * es], es);
    return a;
  };
  for (Part& part : parts) {
    for (const auto& [name, src] : P.attributes) {
      if (name != uv_name) {
        part.attributes.emplace_back(name, copy_attr(src, part.src_vertex));
        continue;
      }
      RawAttribute a;
      a.component_type = kFloat;
      a.components = 2;
      a.count = part.src_vertex.size();
      a.accessor = src.accessor;
      a.had_min_max = src.had_min_max;
      a.data.resize(a.count * 8);
      for (size_t i = 0; i < a.count; ++i) {
        const Vec2& t = out.texcoords[static_cast<size_t>(part.src_texcoord[i])];
        const float uv[2] = {static_cast<float>(t.x()), static_cast<float>(1.0 - t.y())};
        if (!std::isfinite(uv[0]) || !std::isfinite(uv[1])) throw GltfError(where + ": non-finite output texture coordinate");
        std::memcpy(&a.data[i * 8], uv, 8);
      }
      part.attributes.emplace_back(name, std::move(a));
    }
    for (const auto& tl : P.targets) {
      AttributeList nl;
      for (const auto& [name, src] : tl) nl.emplace_back(name, copy_attr(src, part.src_vertex));
      part.targets.push_back(std::move(nl));
    }
  }
  return parts;
}

/// min/max of every component, as glTF wants them (raw values of the component type).
void min_max(const RawAttribute& a, ojson* mn, ojson* mx) {
  *mn = ojson::array();
  *mx = ojson::array();
  RawAttribute raw = a;
  raw.normalized = false;
  for (int c = 0; c < a.components; ++c) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (size_t i = 0; i < a.count; ++i) {
      const double v = raw.value(i, c);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (a.component_type == kFloat) {
      mn->push_back(static_cast<double>(static_cast<float>(lo)));
      mx->push_back(static_cast<double>(static_cast<float>(hi)));
    } else {
      mn->push_back(static_cast<long long>(lo));
      mx->push_back(static_cast<long long>(hi));
    }
  }
}

/// The edit of one document.
class DocumentWriter {
 public:
  DocumentWriter(const Document& d, const TexturedMesh& out, const GltfWriteOptions& options,
                 std::vector<std::string> page_uri, const std::vector<EncodedPage>& pages)
      : d_(d), out_(out), options_(options), page_uri_(std::move(page_uri)), pages_(pages), j_(d.json) {
    old_view_count_ = j_.contains("bufferViews") ? j_["bufferViews"].size() : 0;
    old_refs_ = view_references();
    count_accessor_references();
  }

  /// Runs the edit; returns the document bytes and adds external buffer files to `files`.
  std::string write(const GltfOutputPaths& paths, std::vector<OutputFile>* files, ojson* report);

 private:
  struct NewView {
    std::vector<uint8_t> bytes;
    int target = 0;
  };

  int add_view(std::vector<uint8_t> bytes, int target) {
    new_views_.push_back({std::move(bytes), target});
    return static_cast<int>(old_view_count_ + new_views_.size() - 1);
  }
  std::set<int> view_references() const;
  void count_accessor_references();
  int place_accessor(int original, const ojson& acc);
  ojson accessor_json(const RawAttribute& a, int view, bool with_min_max) const;
  int page_texture(int page, int input_texture);
  int part_material(int input_material, int page);
  void rewrite_primitive(const Primitive& P);
  ojson encode_part(const Part& part, const Primitive& P, ojson prim);
  void collect_garbage_textures();
  size_t rebuild_buffers();
  void update_extension_lists();

  const Document& d_;
  const TexturedMesh& out_;
  const GltfWriteOptions& options_;
  std::vector<std::string> page_uri_;  ///< per output page: URI for this document, or "" to embed
  const std::vector<EncodedPage>& pages_;
  ojson j_;
  size_t old_view_count_ = 0;
  std::set<int> old_refs_;
  std::vector<NewView> new_views_;
  std::map<int, int> accessor_refs_;        ///< references in the input, by accessor
  std::set<int> reused_accessors_;
  std::map<int, int> texture_of_page_;
  std::map<std::pair<int, int>, int> material_of_;  ///< (input material, page) -> output material
  std::set<int> material_in_place_;
  std::vector<std::vector<uint8_t>> buffers_out_;
  size_t rewritten_ = 0, split_ = 0, draco_written_ = 0, draco_positions_changed_ = 0;
  ojson dropped_extensions_ = ojson::array();
};

std::set<int> DocumentWriter::view_references() const {
  std::set<int> refs;
  if (j_.contains("accessors"))
    for (const auto& a : j_["accessors"]) {
      if (a.contains("bufferView")) refs.insert(a["bufferView"].get<int>());
      if (a.contains("sparse")) {
        refs.insert(a["sparse"]["indices"].value("bufferView", -1));
        refs.insert(a["sparse"]["values"].value("bufferView", -1));
      }
    }
  if (j_.contains("images"))
    for (const auto& i : j_["images"])
      if (i.contains("bufferView")) refs.insert(i["bufferView"].get<int>());
  if (j_.contains("meshes"))
    for (const auto& m : j_["meshes"])
      for (const auto& p : m.value("primitives", ojson::array()))
        if (p.contains("extensions") && p["extensions"].contains("KHR_draco_mesh_compression"))
          refs.insert(p["extensions"]["KHR_draco_mesh_compression"].value("bufferView", -1));
  refs.erase(-1);
  return refs;
}

void DocumentWriter::count_accessor_references() {
  auto add = [&](const ojson& v) {
    if (v.is_number_integer()) ++accessor_refs_[v.get<int>()];
  };
  if (j_.contains("meshes"))
    for (const auto& m : j_["meshes"])
      for (const auto& p : m.value("primitives", ojson::array())) {
        for (const auto& a : p.value("attributes", ojson::object())) add(a);
        if (p.contains("indices")) add(p["indices"]);
        for (const auto& t : p.value("targets", ojson::array()))
          for (const auto& a : t) add(a);
      }
  if (j_.contains("skins"))
    for (const auto& s : j_["skins"])
      if (s.contains("inverseBindMatrices")) add(s["inverseBindMatrices"]);
  if (j_.contains("animations"))
    for (const auto& an : j_["animations"])
      for (const auto& s : an.value("samplers", ojson::array())) {
        if (s.contains("input")) add(s["input"]);
        if (s.contains("output")) add(s["output"]);
      }
  if (j_.contains("nodes"))
    for (const auto& n : j_["nodes"])
      if (n.contains("extensions") && n["extensions"].contains("EXT_mesh_gpu_instancing"))
        for (const auto& a : n["extensions"]["EXT_mesh_gpu_instancing"].value("attributes", ojson::object())) add(a);
}

/// Puts accessor JSON `acc` in the slot of `original` when only the rewritten primitive used it
/// (indices stay stable for anything else that names accessors), else appends it.
int DocumentWriter::place_accessor(int original, const ojson& acc) {
  ojson& accs = j_["accessors"];
  if (original >= 0 && accessor_refs_[original] == 1 && !reused_accessors_.count(original)) {
    reused_accessors_.insert(original);
    ojson& slot = accs[static_cast<size_t>(original)];
    ojson merged = acc;
    for (const char* keep : {"name", "extras", "extensions"})
      if (slot.contains(keep)) merged[keep] = slot[keep];
    slot = merged;
    return original;
  }
  accs.push_back(acc);
  return static_cast<int>(accs.size()) - 1;
}

ojson DocumentWriter::accessor_json(const RawAttribute& a, int view, bool with_min_max) const {
  ojson acc = ojson::object();
  if (view >= 0) acc["bufferView"] = view;
  acc["componentType"] = a.component_type;
  if (a.normalized) acc["normalized"] = true;
  acc["count"] = a.count;
  acc["type"] = components_type(a.components);
  if (with_min_max) {
    ojson mn, mx;
    min_max(a, &mn, &mx);
    acc["max"] = mx;
    acc["min"] = mn;
  }
  return acc;
}

/// The output texture of page `page` in this document (created on first use from `input_texture`).
int DocumentWriter::page_texture(int page, int input_texture) {
  auto it = texture_of_page_.find(page);
  if (it != texture_of_page_.end()) return it->second;
  ojson tex = j_["textures"][static_cast<size_t>(input_texture)];
  tex.erase("source");
  if (tex.contains("extensions")) {
    for (auto e = tex["extensions"].begin(); e != tex["extensions"].end();)
      e = is_image_source_extension(e.key()) ? tex["extensions"].erase(e) : std::next(e);
    if (tex["extensions"].empty()) tex.erase("extensions");
  }
  ojson img = ojson::object();
  const EncodedPage& ep = pages_.at(static_cast<size_t>(page));
  if (!page_uri_[static_cast<size_t>(page)].empty()) {
    img["uri"] = page_uri_[static_cast<size_t>(page)];
  } else {
    img["bufferView"] = add_view(ep.bytes, 0);
    img["mimeType"] = ep.mime;
  }
  if (!j_.contains("images")) j_["images"] = ojson::array();
  j_["images"].push_back(img);
  tex["source"] = j_["images"].size() - 1;
  j_["textures"].push_back(tex);
  const int t = static_cast<int>(j_["textures"].size()) - 1;
  texture_of_page_[page] = t;
  return t;
}

int DocumentWriter::part_material(int input_material, int page) {
  auto it = material_of_.find({input_material, page});
  if (it != material_of_.end()) return it->second;
  ojson& mats = j_["materials"];
  const int input_texture = mats[static_cast<size_t>(input_material)]["pbrMetallicRoughness"]["baseColorTexture"]["index"].get<int>();
  const int tex = page_texture(page, input_texture);
  int m = input_material;
  if (material_in_place_.count(input_material)) {
    ojson copy = d_.json["materials"][static_cast<size_t>(input_material)];
    if (copy.contains("name")) copy["name"] = copy["name"].get<std::string>() + "_page" + std::to_string(page);
    mats.push_back(copy);
    m = static_cast<int>(mats.size()) - 1;
  }
  material_in_place_.insert(input_material);
  mats[static_cast<size_t>(m)]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = tex;
  material_of_[{input_material, page}] = m;
  return m;
}

ojson DocumentWriter::encode_part(const Part& part, const Primitive& P, ojson prim) {
  const std::string where = d_.path + ": mesh " + std::to_string(P.mesh) + " primitive " + std::to_string(P.prim);
  const ojson original_attributes = d_.json["meshes"][static_cast<size_t>(P.mesh)]["primitives"][static_cast<size_t>(P.prim)]["attributes"];
  const bool draco = options_.draco != DracoOutput::None && part.targets.empty();
  prim["mode"] = 4;
  if (prim.contains("extensions")) {
    prim["extensions"].erase("KHR_draco_mesh_compression");
    if (prim["extensions"].empty()) prim.erase("extensions");
  }
  ojson attrs = ojson::object();
  if (draco) {
    std::vector<int> ids;
    const std::vector<uint8_t> bytes =
        draco_encode(part.tri, part.src_vertex.size(), part.attributes, options_, P.position_quantization, &ids, where);
    // Decode what was written: accessor min/max must describe the decoded values, and positions
    // that quantisation moved are counted.
    std::vector<DracoAttributeRequest> req;
    for (size_t i = 0; i < part.attributes.size(); ++i) {
      const auto& a = part.attributes[i].second;
      req.push_back({part.attributes[i].first, ids[i], a.component_type, a.components, a.normalized, -1});
    }
    const DracoDecoded dd = draco_decode(bytes.data(), bytes.size(), req, where + " (written Draco data)");
    if (dd.faces != part.tri || dd.num_points != part.src_vertex.size())
      throw GltfError(where + ": written Draco data does not decode to the same faces");
    const int view = add_view(bytes, 0);
    ojson ext = {{"bufferView", view}, {"attributes", ojson::object()}};
    for (size_t i = 0; i < dd.attributes.size(); ++i) {
      const auto& [name, a] = dd.attributes[i];
      if (name == "POSITION")
        for (size_t v = 0; v < a.count; ++v)
          draco_positions_changed_ += std::memcmp(&a.data[v * a.elem_size()], &part.attributes[i].second.data[v * a.elem_size()], a.elem_size()) != 0;
      const int orig = original_attributes.contains(name) ? original_attributes[name].get<int>() : -1;
      attrs[name] = place_accessor(orig, accessor_json(a, -1, name == "POSITION" || a.had_min_max));
      ext["attributes"][name] = ids[i];
    }
    prim["extensions"]["KHR_draco_mesh_compression"] = ext;
    ++draco_written_;
  } else {
    for (const auto& [name, a] : part.attributes) {
      const int orig = original_attributes.contains(name) ? original_attributes[name].get<int>() : -1;
      attrs[name] = place_accessor(orig, accessor_json(a, add_view(a.data, 34962), name == "POSITION" || a.had_min_max));
    }
    if (!part.targets.empty()) {
      ojson targets = ojson::array();
      for (size_t t = 0; t < part.targets.size(); ++t) {
        ojson tj = ojson::object();
        for (const auto& [name, a] : part.targets[t]) {
          const int orig = prim.contains("targets") ? prim["targets"][t].value(name, -1) : -1;
          tj[name] = place_accessor(orig, accessor_json(a, add_view(a.data, 34962), name == "POSITION" || a.had_min_max));
        }
        targets.push_back(tj);
      }
      prim["targets"] = targets;
    }
  }
  prim["attributes"] = attrs;
  // Indices: 16 bits when they fit, else 32.
  RawAttribute idx;
  idx.components = 1;
  idx.count = part.tri.size();
  const bool small = part.src_vertex.size() < 65535;
  idx.component_type = small ? kUShort : kUInt;
  idx.data.resize(idx.count * (small ? 2 : 4));
  for (size_t i = 0; i < idx.count; ++i) {
    if (small) {
      const uint16_t v = static_cast<uint16_t>(part.tri[i]);
      std::memcpy(&idx.data[i * 2], &v, 2);
    } else {
      std::memcpy(&idx.data[i * 4], &part.tri[i], 4);
    }
  }
  const int orig_idx = prim.value("indices", -1);
  prim["indices"] = place_accessor(orig_idx, accessor_json(idx, draco ? -1 : add_view(idx.data, 34963), false));
  prim["material"] = part_material(P.material, part.page);
  return prim;
}

void DocumentWriter::rewrite_primitive(const Primitive& P) {
  const std::string where = d_.path + ": mesh " + std::to_string(P.mesh) + " primitive " + std::to_string(P.prim);
  if (options_.draco != DracoOutput::None && !P.targets.empty())
    throw GltfError(where + ": morph targets cannot be Draco-compressed (KHR_draco_mesh_compression); write without output.draco");
  const std::vector<Part> parts = build_parts(P, out_, where);
  ojson& prims = j_["meshes"][static_cast<size_t>(P.mesh)]["primitives"];
  ojson original = prims[static_cast<size_t>(P.prim)];
  if (parts.size() > 1 && original.contains("extensions")) {
    // Splitting changes the primitive's face list: extensions that describe it (a BVH, ...) would
    // be wrong, so they are dropped and reported. Draco is handled by the writer itself.
    for (auto e = original["extensions"].begin(); e != original["extensions"].end();) {
      if (e.key() != "KHR_draco_mesh_compression") {
        dropped_extensions_.push_back({{"mesh", P.mesh}, {"primitive", P.prim}, {"extension", e.key()}});
        e = original["extensions"].erase(e);
      } else {
        ++e;
      }
    }
  }
  for (size_t k = 0; k < parts.size(); ++k) {
    ojson prim = encode_part(parts[k], P, k == 0 ? original : [&] {
      ojson c = original;
      c.erase("indices");
      c.erase("targets");
      return c;
    }());
    if (k == 0)
      prims[static_cast<size_t>(P.prim)] = prim;
    else
      prims.push_back(prim);
  }
  ++rewritten_;
  split_ += parts.size() > 1;
}

/// Removes textures no material names and images no texture names, renumbering references.
void DocumentWriter::collect_garbage_textures() {
  if (!j_.contains("textures")) return;
  // Texture references: every object under a key ending in "Texture" with an "index" (the glTF
  // textureInfo convention, also in KHR_materials_* extensions).
  std::function<void(ojson&, const std::function<void(ojson&)>&)> each_texinfo = [&](ojson& j, const std::function<void(ojson&)>& fn) {
    if (!j.is_object()) return;
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      if (k.size() > 7 && k.compare(k.size() - 7, 7, "Texture") == 0 && it->is_object() && it->contains("index"))
        fn((*it)["index"]);
      else if (it->is_object())
        each_texinfo(*it, fn);
    }
  };
  const size_t nt = j_["textures"].size();
  std::vector<int> used_t(nt, 0);
  for (auto& m : j_["materials"]) each_texinfo(m, [&](ojson& i) { used_t.at(i.get<size_t>()) = 1; });
  std::vector<int> remap_t(nt, -1);
  ojson kept_t = ojson::array();
  for (size_t t = 0; t < nt; ++t)
    if (used_t[t]) {
      remap_t[t] = static_cast<int>(kept_t.size());
      kept_t.push_back(j_["textures"][t]);
    }
  for (auto& m : j_["materials"]) each_texinfo(m, [&](ojson& i) { i = remap_t[i.get<size_t>()]; });
  j_["textures"] = kept_t;
  if (!j_.contains("images")) return;
  const size_t ni = j_["images"].size();
  std::vector<int> used_i(ni, 0);
  auto each_source = [&](const std::function<void(ojson&)>& fn) {
    for (auto& t : j_["textures"]) {
      if (t.contains("source")) fn(t["source"]);
      if (t.contains("extensions"))
        for (auto& e : t["extensions"].items())
          if (e.value().is_object() && e.value().contains("source")) fn(e.value()["source"]);
    }
  };
  each_source([&](ojson& s) { used_i.at(s.get<size_t>()) = 1; });
  std::vector<int> remap_i(ni, -1);
  ojson kept_i = ojson::array();
  for (size_t i = 0; i < ni; ++i)
    if (used_i[i]) {
      remap_i[i] = static_cast<int>(kept_i.size());
      kept_i.push_back(j_["images"][i]);
    }
  each_source([&](ojson& s) { s = remap_i[s.get<size_t>()]; });
  j_["images"] = kept_i;
  if (j_["images"].empty()) j_.erase("images");
  if (j_["textures"].empty()) j_.erase("textures");
}

/// Renumbers every buffer view reference of glTF JSON `j` we know (accessors and their sparse
/// parts, images, KHR_draco_mesh_compression) through remap (old view -> new view).
void remap_view_references(ojson& j, const std::vector<int>& remap) {
  auto fix = [&](ojson& o, const char* key) {
    if (o.contains(key)) o[key] = remap.at(o[key].get<size_t>());
  };
  if (j.contains("accessors"))
    for (auto& a : j["accessors"]) {
      fix(a, "bufferView");
      if (a.contains("sparse")) {
        fix(a["sparse"]["indices"], "bufferView");
        fix(a["sparse"]["values"], "bufferView");
      }
    }
  if (j.contains("images"))
    for (auto& i : j["images"]) fix(i, "bufferView");
  if (j.contains("meshes"))
    for (auto& m : j["meshes"])
      for (auto& p : m["primitives"])
        if (p.contains("extensions") && p["extensions"].contains("KHR_draco_mesh_compression"))
          fix(p["extensions"]["KHR_draco_mesh_compression"], "bufferView");
}

/// Lays out every kept and new buffer view again, 4-byte aligned; returns bytes of unused views kept.
size_t DocumentWriter::rebuild_buffers() {
  if (!j_.contains("bufferViews")) j_["bufferViews"] = ojson::array();
  ojson& views = j_["bufferViews"];
  for (const NewView& nv : new_views_) {
    ojson v = {{"buffer", 0}, {"byteLength", nv.bytes.size()}};
    if (nv.target) v["target"] = nv.target;
    views.push_back(v);
  }
  for (const auto& v : views)
    if (v.contains("extensions") && v["extensions"].contains("EXT_meshopt_compression"))
      throw GltfError(d_.path + ": EXT_meshopt_compression buffer views cannot be laid out again (decompress the file first)");
  // Views freed by the edit can go unless a view that nothing we know names (an extension may)
  // sits after them: its index must not move.
  const std::set<int> now = view_references();
  int last_unknown = -1;
  for (int v = 0; v < static_cast<int>(old_view_count_); ++v)
    if (!old_refs_.count(v)) last_unknown = v;
  std::vector<int> remap(views.size());
  std::vector<uint8_t> keep(views.size(), 1);
  size_t unused_kept = 0;
  for (int v = 0; v < static_cast<int>(old_view_count_); ++v)
    if (old_refs_.count(v) && !now.count(v)) {
      if (v > last_unknown)
        keep[static_cast<size_t>(v)] = 0;
      else
        unused_kept += views[static_cast<size_t>(v)].value("byteLength", size_t{0});
    }
  // Bytes of every view, then new buffers.
  if (!j_.contains("buffers") || j_["buffers"].empty()) {
    j_["buffers"] = ojson::array({ojson::object()});
    if (!d_.binary) j_["buffers"][0]["uri"] = fs::path(d_.path).stem().string() + ".bin";
  }
  std::vector<std::vector<uint8_t>> data(j_["buffers"].size());
  ojson kept = ojson::array();
  for (size_t v = 0; v < views.size(); ++v) {
    if (!keep[v]) {
      remap[v] = -1;
      continue;
    }
    ojson view = views[v];
    const uint8_t* src;
    size_t len;
    if (v < old_view_count_) {
      const auto& buf = d_.buffers.at(view["buffer"].get<size_t>());
      src = buf.data() + view.value("byteOffset", size_t{0});
      len = view["byteLength"].get<size_t>();
    } else {
      src = new_views_[v - old_view_count_].bytes.data();
      len = new_views_[v - old_view_count_].bytes.size();
    }
    auto& dst = data.at(view["buffer"].get<size_t>());
    while (dst.size() % 4) dst.push_back(0);
    view["byteOffset"] = dst.size();
    if (view["byteOffset"] == 0) view.erase("byteOffset");
    dst.insert(dst.end(), src, src + len);
    remap[v] = static_cast<int>(kept.size());
    kept.push_back(view);
  }
  j_["bufferViews"] = kept;
  if (kept.empty()) j_.erase("bufferViews");
  remap_view_references(j_, remap);
  for (size_t b = 0; b < data.size(); ++b) {
    while (data[b].size() % 4) data[b].push_back(0);
    j_["buffers"][b]["byteLength"] = data[b].size();
  }
  buffers_out_ = std::move(data);
  return unused_kept;
}

void DocumentWriter::update_extension_lists() {
  std::set<std::string> texture_exts;
  bool draco = false;
  if (j_.contains("textures"))
    for (const auto& t : j_["textures"])
      if (t.contains("extensions"))
        for (const auto& e : t["extensions"].items()) texture_exts.insert(e.key());
  if (j_.contains("meshes"))
    for (const auto& m : j_["meshes"])
      for (const auto& p : m["primitives"])
        draco |= p.contains("extensions") && p["extensions"].contains("KHR_draco_mesh_compression");
  for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
    ojson l = j_.contains(list) ? j_[list] : ojson::array();
    ojson kept = ojson::array();
    bool has_draco = false;
    for (const auto& e : l) {
      const std::string n = e.get<std::string>();
      if (is_image_source_extension(n) && !texture_exts.count(n)) continue;
      if (n == "KHR_draco_mesh_compression") {
        if (!draco) continue;
        has_draco = true;
      }
      kept.push_back(e);
    }
    if (draco && !has_draco) kept.push_back("KHR_draco_mesh_compression");
    if (kept.empty())
      j_.erase(list);
    else
      j_[list] = kept;
  }
}

std::string DocumentWriter::write(const GltfOutputPaths& paths, std::vector<OutputFile>* files, ojson* report) {
  for (const Primitive& P : d_.primitives)
    if (P.texture >= 0) rewrite_primitive(P);
  collect_garbage_textures();
  const size_t unused = rebuild_buffers();
  update_extension_lists();
  std::string bin;
  for (size_t b = 0; b < buffers_out_.size(); ++b) {
    ojson& bj = j_["buffers"][b];
    const std::vector<uint8_t>& bytes = buffers_out_[b];
    if (d_.binary && b == 0 && !bj.contains("uri")) {
      bin.assign(bytes.begin(), bytes.end());
      continue;
    }
    if (!bj.contains("uri")) throw GltfError(d_.path + ": buffer " + std::to_string(b) + " has no uri and is not the GLB's BIN chunk");
    const std::string uri = bj["uri"].get<std::string>();
    if (uri.rfind("data:", 0) == 0)
      bj["uri"] = "data:application/octet-stream;base64," + base64_encode(bytes.data(), bytes.size());
    else
      files->push_back({paths.map_path((fs::path(d_.base_dir) / url_decode(uri)).string()), std::string(bytes.begin(), bytes.end())});
  }
  *report = {{"file", d_.path},
             {"rewritten_primitives", rewritten_},
             {"split_primitives", split_},
             {"draco_primitives_written", draco_written_},
             {"draco_positions_changed", draco_positions_changed_},
             {"unused_buffer_view_bytes_kept", unused},
             {"primitive_extensions_dropped", dropped_extensions_}};
  if (!d_.binary) return j_.dump(2) + "\n";
  std::string js = j_.dump();
  while (js.size() % 4) js += ' ';
  std::string out;
  auto put32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
  };
  const size_t total = 12 + 8 + js.size() + (bin.empty() ? 0 : 8 + bin.size());
  if (total > std::numeric_limits<uint32_t>::max()) throw GltfError(d_.path + ": output GLB would exceed 4 GiB");
  out += "glTF";
  put32(2);
  put32(static_cast<uint32_t>(total));
  put32(static_cast<uint32_t>(js.size()));
  put32(0x4E4F534Au);
  out += js;
  if (!bin.empty()) {
    put32(static_cast<uint32_t>(bin.size()));
    put32(0x004E4942u);
    out += bin;
  }
  return out;
}

}  // namespace

GltfOutput write_gltf(const GltfModel& in, const TexturedMesh& out, const std::vector<EncodedPage>& pages,
                      const GltfOutputPaths& paths, const GltfWriteOptions& options) {
  const std::string who = in.inputs.empty() ? std::string("write_gltf") : in.inputs.front().path;
  if (!in.documents || in.documents->size() != in.inputs.size()) throw GltfError(who + ": model was not read by read_gltf");
  if (paths.documents.size() != in.inputs.size())
    throw GltfError(who + ": " + std::to_string(paths.documents.size()) + " output paths for " + std::to_string(in.inputs.size()) + " documents");
  if (out.faces.size() != in.mesh.faces.size())
    throw GltfError(who + ": output mesh has " + std::to_string(out.faces.size()) + " faces, the input " + std::to_string(in.mesh.faces.size()));
  if (pages.size() != out.pages.size())
    throw GltfError(who + ": " + std::to_string(pages.size()) + " encoded pages for " + std::to_string(out.pages.size()) + " output pages");
  for (size_t f = 0; f < out.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec3& a = in.mesh.corner_position(f, k);
      const Vec3& b = out.corner_position(f, k);
      if (std::memcmp(a.data(), b.data(), sizeof(double) * 3) != 0)
        throw GltfError(who + ": output face " + std::to_string(f) + " moved a corner position (the writer keeps input positions)");
      if ((in.mesh.faces[f].page == kNoPage) != (out.faces[f].page == kNoPage))
        throw GltfError(who + ": output face " + std::to_string(f) + " changed from textured to untextured or back");
    }
  for (const auto& p : pages)
    if (p.mime != "image/jpeg" && p.mime != "image/png") throw GltfError(who + ": output page of type '" + p.mime + "' (expected JPEG or PNG)");
  GltfOutput result;
  // Page images: external files where the input's were, named after them; else embedded.
  std::vector<std::string> page_file(out.pages.size());
  std::map<std::string, int> stem_uses;
  std::vector<int> first_input_page(out.pages.size(), -1);
  for (size_t f = 0; f < out.faces.size(); ++f) {
    const int p = out.faces[f].page;
    if (p >= 0 && first_input_page[static_cast<size_t>(p)] < 0) first_input_page[static_cast<size_t>(p)] = in.mesh.faces[f].page;
  }
  for (size_t p = 0; p < out.pages.size(); ++p) {
    const int ip = first_input_page[p];
    if (ip < 0) continue;
    const GltfPageSource& src = in.page_source[static_cast<size_t>(ip)];
    if (src.image_file.empty()) continue;
    const fs::path ipath(src.image_file);
    const std::string key = (ipath.parent_path() / ipath.stem()).string();
    const int k = stem_uses[key]++;
    const fs::path name = ipath.parent_path() / (ipath.stem().string() + (k ? "_" + std::to_string(k) : "") + ext_of_mime(pages[p].mime));
    page_file[p] = paths.map_path(name.string());
    result.files.push_back({page_file[p], std::string(pages[p].bytes.begin(), pages[p].bytes.end())});
  }
  result.report = {{"documents", ojson::array()}};
  for (size_t i = 0; i < in.inputs.size(); ++i) {
    const fs::path doc_dir = fs::absolute(paths.documents[i]).parent_path();
    std::vector<std::string> uri(out.pages.size());
    for (size_t p = 0; p < out.pages.size(); ++p)
      if (!page_file[p].empty()) uri[p] = fs::absolute(page_file[p]).lexically_relative(doc_dir).generic_string();
    DocumentWriter w((*in.documents)[i], out, options, uri, pages);
    ojson rep;
    result.documents.push_back(w.write(paths, &result.files, &rep));
    result.report["documents"].push_back(nlohmann::json::parse(rep.dump()));
  }
  return result;
}

}  // namespace texdefrag
