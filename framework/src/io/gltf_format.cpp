// glTF behind the ModelFormat interface (see texdefrag/io/gltf_format.h).
#include "texdefrag/io/gltf_format.h"

#include "texdefrag/io/jpeg_quality.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace fs = std::filesystem;

namespace texdefrag {

namespace {

std::string under_root(const std::string& file, const std::string& root, const std::string& who) {
  const fs::path rel = fs::absolute(file).lexically_normal().lexically_relative(fs::absolute(root).lexically_normal());
  if (rel.empty() || *rel.begin() == "..")
    throw FormatError(who + ": " + file + " lies outside " + root + " (the output mirrors that folder's layout)");
  return rel.generic_string();
}

LoadedModel loaded_from(GltfModel g, const std::string& root) {
  LoadedModel m;
  m.path = g.inputs.front().path;
  m.format = "gltf";
  m.mesh = g.mesh;
  m.positions_stretched = g.positions_stretched;
  m.page_images.resize(g.mesh.pages.size());
  for (size_t p = 0; p < g.mesh.pages.size(); ++p) {
    const GltfPageSource& s = g.page_source[p];
    PageEncoding e;
    if (!s.image_file.empty()) {
      e = page_encoding_of_file(s.image_file);
      m.input_files.push_back(s.image_file);
    } else {
      m.page_images[p] = read_gltf_page(g, static_cast<int>(p));
      e.format = s.mime == "image/png" ? "png" : "jpeg";
      e.bytes = s.embedded.size();
      if (e.format == "jpeg") {
        e.jpeg_quality = estimate_jpeg_quality(s.embedded.data(), s.embedded.size());
        e.jpeg_subsampling = read_jpeg_subsampling(s.embedded.data(), s.embedded.size());
      }
      e.bits = image_bits_of_stream(s.embedded.data(), s.embedded.size());
    }
    if (!s.replaces_ktx2.empty()) m.input_files.push_back(s.replaces_ktx2);
    m.page_encodings.push_back(e);
  }
  for (const auto& in : g.inputs) m.input_files.push_back(in.path);
  auto src = std::make_shared<GltfSource>();
  src->model = std::move(g);
  src->root = root;
  m.source = src;
  return m;
}

}  // namespace

std::vector<uint8_t> encode_image(const Image& image, const PageWriteOptions& options) {
  if (options.format == ImageFormat::Jpeg) return encode_jpeg(image, options.jpeg_quality, options.jpeg_subsampling, "page", options.jpeg_coding);
  static std::atomic<unsigned> counter{0};
  const fs::path tmp = fs::temp_directory_path() / ("texdefrag-page-" + std::to_string(::getpid()) + "-" +
                                                    std::to_string(counter++) +
                                                    (options.format == ImageFormat::Jpeg ? ".jpg" : ".png"));
  write_image(tmp.string(), image, options.format, options.jpeg_quality, options.jpeg_subsampling, options.jpeg_coding);
  std::ifstream in(tmp, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  fs::remove(tmp);
  return bytes;
}

bool GltfFormat::can_read(const std::string& path) const {
  const std::string e = lower_extension(path);
  if (e == "glb" || e == "gltf") return true;
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  return in.gcount() == 4 && std::string(magic, 4) == "glTF";
}

LoadedModel GltfFormat::read(const std::string& path) const {
  try {
    const std::string root = fs::path(path).parent_path().empty() ? "." : fs::path(path).parent_path().string();
    return loaded_from(read_gltf(path), root);
  } catch (const GltfError& e) {
    throw FormatError(e.what());
  }
}

LoadedModel GltfFormat::read_group(const std::vector<GltfInput>& inputs, const std::string& root) const {
  try {
    return loaded_from(read_gltf(inputs), root);
  } catch (const GltfError& e) {
    throw FormatError(e.what());
  }
}

GltfWriteOptions GltfFormat::write_options_for(const PageWriteOptions& page_options) const {
  GltfWriteOptions wo = write_options;
  const json& oo = page_options.output_options;
  if (oo.contains("draco")) {
    const std::string d = oo["draco"].get<std::string>();
    wo.draco = d == "lossless" ? DracoOutput::Lossless : d == "quantized" ? DracoOutput::Quantized : DracoOutput::None;
  }
  if (oo.contains("draco_position_bits")) wo.draco_position_bits = oo["draco_position_bits"].get<int>();
  if (oo.contains("draco_texcoord_bits")) wo.draco_texcoord_bits = oo["draco_texcoord_bits"].get<int>();
  if (oo.contains("draco_generic_bits")) wo.draco_generic_bits = oo["draco_generic_bits"].get<int>();
  return wo;
}

TexcoordReadBack GltfFormat::texcoord_read_back(const PageWriteOptions& page_options) const {
  if (write_options_for(page_options).draco == DracoOutput::Quantized) return {};
  // note: the writer stores (u, 1 - v) as floats; a reader turns the second back with 1 - v.
  return [](const Vec2& t) {
    return Vec2(stored_as_float32(t.x()), 1.0 - stored_as_float32(1.0 - t.y()));
  };
}

GltfOutput GltfFormat::build(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                             const std::vector<std::string>& names, const PageWriteOptions& page_options) const {
  const auto* src = dynamic_cast<const GltfSource*>(in.source.get());
  if (!src) throw FormatError(in.path + ": not read by the glTF format");
  std::vector<EncodedPage> enc;
  for (size_t p = 0; p < pages.size(); ++p)
    enc.push_back({page_options.format == ImageFormat::Jpeg ? "image/jpeg" : "image/png", encode_page(pages, p, page_options)});
  GltfOutputPaths paths;
  paths.documents = names;
  const std::string root = src->root, who = in.path;
  paths.map_path = [root, who](const std::string& f) { return under_root(f, root, who); };
  size_t page_bytes = 0;
  for (const auto& e : enc) page_bytes += e.bytes.size();
  const GltfWriteOptions wo = write_options_for(page_options);
  try {
    GltfOutput o = write_gltf(src->model, out_mesh, enc, paths, wo);
    o.report["page_bytes"] = page_bytes;
    return o;
  } catch (const GltfError& e) {
    throw FormatError(e.what());
  }
}

WriteResult GltfFormat::write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                              const std::string& stem, const PageWriteOptions& page_options, OutputSet& files) const {
  const auto* src = dynamic_cast<const GltfSource*>(in.source.get());
  if (!src) throw FormatError(in.path + ": not read by the glTF format");
  std::vector<std::string> names;
  if (src->model.inputs.size() == 1) {
    names.push_back(stem + fs::path(in.path).extension().string());
  } else {
    for (const auto& i : src->model.inputs) names.push_back(under_root(i.path, src->root, in.path));
  }
  const GltfOutput o = build(in, out_mesh, pages, names, page_options);
  WriteResult r;
  for (size_t i = 0; i < names.size(); ++i) {
    files.write_file(names[i], o.documents[i]);
    r.files.push_back(files.final_path(names[i]));
  }
  r.main_file = r.files.front();
  for (const auto& f : o.files) {
    files.write_file(f.path, f.bytes);
    r.files.push_back(files.final_path(f.path));
  }
  r.page_bytes = o.report.value("page_bytes", size_t{0});
  r.report = o.report;
  return r;
}

}  // namespace texdefrag
