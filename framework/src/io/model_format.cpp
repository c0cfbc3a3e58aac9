// Format registry, page encodings and the direct output seam (see texdefrag/io/model_format.h).
#include "texdefrag/io/model_format.h"

#include "texdefrag/core/uv_overlap.h"
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/io/gltf_format.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/io/obj_format.h"
#include "texdefrag/io/osgb.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <string_view>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

/// Orientation of a face's UV triangle from its texture coordinates mapped by `uv`: +1, -1 or 0
/// (core/uv_overlap.h's exact orient2d).
template <class UV>
int uv_turn(const TexturedMesh& m, const Face& f, const UV& uv) {
  return orient2d(uv(m.texcoords[static_cast<size_t>(f.vt[0])]), uv(m.texcoords[static_cast<size_t>(f.vt[1])]),
                  uv(m.texcoords[static_cast<size_t>(f.vt[2])]));
}

}  // namespace

TexcoordReadBack ModelFormat::texcoord_read_back(const PageWriteOptions& /*page_options*/) const {
  return [](const Vec2& t) { return t; };
}

double stored_as_float32(double x) {
  volatile float f = static_cast<float>(x);
  return static_cast<double>(f);
}

size_t faces_turned_by(const TexturedMesh& in, const TexturedMesh& out, const TexcoordReadBack& read_back) {
  const auto same = [](const Vec2& t) { return t; };
  size_t turned = 0;
  for (size_t i = 0; i < out.faces.size(); ++i) {
    const Face& f = out.faces[i];
    if (f.vt[0] == kNoIndex) continue;
    if (i < in.faces.size() && (in.faces[i].vt[0] == kNoIndex || uv_turn(in, in.faces[i], same) == 0)) continue;
    const int given = uv_turn(out, f, same);
    if (given != 0) turned += uv_turn(out, f, read_back) != given;
  }
  return turned;
}

Image LoadedModel::page_image(size_t p) const {
  if (p < page_images.size() && !page_images[p].empty()) return page_images[p];
  return read_image(mesh.pages[p].image_path);
}

const std::vector<const ModelFormat*>& model_formats() {
  // note: the order is the order can_read is asked in; formats that sniff content come after the
  // ones that decide by extension alone.
  static const ObjFormat obj;
  static const OsgbFormat osgb;
  static const GltfFormat gltf;
  static const std::vector<const ModelFormat*> all = {&obj, &osgb, &gltf};
  return all;
}

const ModelFormat* find_model_format(const std::string& name) {
  for (const ModelFormat* f : model_formats())
    if (f->name() == name) return f;
  return nullptr;
}

const ModelFormat& format_for_input(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FormatError(path + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw FormatError(path + ": not a regular file");
  for (const ModelFormat* f : model_formats())
    if (f->can_read(path)) return *f;
  std::string names;
  for (const ModelFormat* f : model_formats()) names += (names.empty() ? "" : ", ") + f->name();
  throw FormatError(path + ": no model format reads this file (known formats: " + names + ")");
}

std::string lower_extension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  if (!e.empty()) e.erase(0, 1);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

std::string sniff_image_format(const uint8_t* data, size_t size, const std::string& name) {
  if (size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) return "jpeg";
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (size >= 8 && std::equal(kPng, kPng + 8, data)) return "png";
  std::string e = lower_extension(name);
  return e == "jpg" ? "jpeg" : e;
}

namespace {

/// Largest BitsPerSample (tag 258) of a TIFF's first image file directory; 0 when unreadable.
int tiff_bits(const std::function<bool(uint64_t, size_t, uint8_t*)>& read, bool le) {
  auto u16 = [le](const uint8_t* b) { return le ? b[0] | b[1] << 8 : b[0] << 8 | b[1]; };
  auto u32 = [le](const uint8_t* b) {
    return le ? uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24
              : uint32_t(b[0]) << 24 | uint32_t(b[1]) << 16 | uint32_t(b[2]) << 8 | uint32_t(b[3]);
  };
  uint8_t b[12];
  if (!read(4, 4, b)) return 0;
  const uint64_t ifd = u32(b);
  if (!read(ifd, 2, b)) return 0;
  const int entries = u16(b);
  for (int k = 0; k < entries && k < 4096; ++k) {
    if (!read(ifd + 2 + 12 * static_cast<uint64_t>(k), 12, b)) return 0;
    if (u16(b) != 258 || u16(b + 2) != 3) continue;  // BitsPerSample, SHORT
    const uint32_t count = u32(b + 4);
    if (count == 0 || count > 64) return 0;
    std::vector<uint8_t> v(2 * static_cast<size_t>(count));
    if (count <= 2) std::copy(b + 8, b + 8 + v.size(), v.begin());
    else if (!read(u32(b + 8), v.size(), v.data())) return 0;
    int bits = 0;
    for (uint32_t i = 0; i < count; ++i) bits = std::max(bits, u16(&v[2 * i]));
    return bits;
  }
  return 1;  // no BitsPerSample: the TIFF default, 1 bit (read as 8)
}

/// JPEG sample precision from the first SOF marker; 0 when none is found in the first 1 MB.
int jpeg_bits(const std::function<bool(uint64_t, size_t, uint8_t*)>& read) {
  uint64_t at = 2;
  uint8_t b[5];
  while (at < (1u << 20) && read(at, 4, b)) {
    if (b[0] != 0xFF) return 0;
    const int marker = b[1];
    if (marker == 0xFF) { ++at; continue; }
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) return read(at + 4, 1, b) ? b[0] : 0;
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) { at += 2; continue; }
    at += 2 + static_cast<uint64_t>(b[2] << 8 | b[3]);
  }
  return 0;
}

}  // namespace

int image_bits(const std::function<bool(uint64_t, size_t, uint8_t*)>& read) {
  uint8_t h[25];
  if (!read(0, 4, h)) return 0;
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (h[0] == 0x89 && read(0, 25, h) && std::equal(kPng, kPng + 8, h)) return h[24];
  if (h[0] == 0xFF && h[1] == 0xD8) return jpeg_bits(read);
  if (h[0] == 'I' && h[1] == 'I' && h[2] == 42 && h[3] == 0) return tiff_bits(read, true);
  if (h[0] == 'M' && h[1] == 'M' && h[2] == 0 && h[3] == 42) return tiff_bits(read, false);
  if (h[0] == 0x76 && h[1] == 0x2F && h[2] == 0x31 && h[3] == 0x01) return 16;  // OpenEXR
  return 0;
}

int image_bits_of_stream(const uint8_t* data, size_t size) {
  return image_bits([data, size](uint64_t off, size_t n, uint8_t* out) {
    if (off > size || n > size - off) return false;
    std::copy(data + off, data + off + n, out);
    return true;
  });
}

PageEncoding page_encoding_of_file(const std::string& path) {
  PageEncoding enc;
  std::error_code ec;
  enc.bytes = static_cast<size_t>(fs::file_size(path, ec));
  if (ec) enc.bytes = 0;
  std::ifstream in(path, std::ios::binary);
  std::vector<char> head(16);
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  enc.format = sniff_image_format(reinterpret_cast<const uint8_t*>(head.data()), static_cast<size_t>(in.gcount()), path);
  if (enc.format == "jpeg") {
    enc.jpeg_quality = estimate_jpeg_quality_of_file(path);
    enc.jpeg_subsampling = read_jpeg_subsampling_of_file(path);
  }
  in.clear();
  enc.bits = image_bits([&in](uint64_t off, size_t n, uint8_t* out) {
    in.seekg(static_cast<std::streamoff>(off));
    in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    const bool ok = in.gcount() == static_cast<std::streamsize>(n);
    in.clear();
    return ok;
  });
  return enc;
}

}  // namespace texdefrag

namespace texdefrag {

namespace {

/// "4:4:4" / "4:2:2" / "4:2:0" -> the enum; empty for anything else.
std::optional<JpegSubsampling> parse_subsampling(const std::string& name) {
  for (JpegSubsampling s : {JpegSubsampling::S444, JpegSubsampling::S422, JpegSubsampling::S420})
    if (name == jpeg_subsampling_name(s)) return s;
  return std::nullopt;
}

}  // namespace

PageWriteOptions choose_page_options(const LoadedModel& in, const std::string& image_format, int jpeg_quality,
                                     bool match_input_quality, const std::string& jpeg_subsampling,
                                     JpegCoding coding) {
  if (image_format != "input" && image_format != "png" && image_format != "jpeg")
    throw FormatError("output.image_format: '" + image_format + "' is not one of input, png, jpeg");
  const std::optional<JpegSubsampling> forced = parse_subsampling(jpeg_subsampling);
  if (!forced && jpeg_subsampling != "input")
    throw FormatError("output.jpeg_subsampling: '" + jpeg_subsampling + "' is not one of input, 4:4:4, 4:2:2, 4:2:0");
  std::vector<uint8_t> used(in.mesh.pages.size(), 0);
  for (const Face& f : in.mesh.faces)
    if (f.page != kNoPage) used[static_cast<size_t>(f.page)] = 1;
  size_t textured_pages = 0, jpeg_pages = 0;
  std::optional<int> quality;
  std::optional<JpegSubsampling> finest;  // the enum is ordered finest first
  for (size_t p = 0; p < used.size(); ++p) {
    if (!used[p]) continue;
    ++textured_pages;
    const PageEncoding* e = p < in.page_encodings.size() ? &in.page_encodings[p] : nullptr;
    if (!e || e->format != "jpeg") continue;
    ++jpeg_pages;
    if (e->jpeg_quality) quality = std::max(quality.value_or(1), *e->jpeg_quality);
    if (e->jpeg_subsampling) finest = std::min(finest.value_or(JpegSubsampling::S420), *e->jpeg_subsampling);
  }
  const bool all_jpeg = textured_pages > 0 && jpeg_pages == textured_pages;
  PageWriteOptions o;
  o.format = image_format == "jpeg" || (image_format == "input" && all_jpeg) ? ImageFormat::Jpeg : ImageFormat::Png;
  o.jpeg_quality_from_input = match_input_quality && quality.has_value();
  o.jpeg_standard_quality = o.jpeg_quality_from_input ? *quality : jpeg_quality;
  o.jpeg_coding = coding;
  o.jpeg_quality = coding.tables == JpegTables::Flat ? flat_quality_for_standard(o.jpeg_standard_quality)
                                                     : o.jpeg_standard_quality;
  o.jpeg_subsampling = forced ? *forced : finest.value_or(JpegSubsampling::S444);
  return o;
}

JpegQualityFit fit_page_quality(const LoadedModel& in, const std::vector<Image>& pages, PageWriteOptions& po,
                                int max_quality) {
  JpegQualityFit none;
  none.quality = po.jpeg_quality;
  if (po.jpeg_coding.tables == JpegTables::Flat) max_quality = flat_quality_for_standard(max_quality);
  if (po.format != ImageFormat::Jpeg || !po.jpeg_quality_from_input || max_quality <= po.jpeg_quality || pages.empty())
    return none;
  std::vector<uint8_t> used(in.mesh.pages.size(), 0);
  for (const Face& f : in.mesh.faces)
    if (f.page != kNoPage) used[static_cast<size_t>(f.page)] = 1;
  for (size_t p = 0; p < used.size(); ++p)
    if (used[p] && (p >= in.page_encodings.size() || in.page_encodings[p].bytes == 0)) return none;
  size_t budget = 0;
  for (const PageEncoding& e : in.page_encodings) budget += e.bytes;
  if (budget == 0) return none;
  std::vector<const Image*> images;
  for (const Image& image : pages) images.push_back(&image);
  JpegQualityFit fit = fit_jpeg_quality(images, po.jpeg_quality, max_quality, po.jpeg_subsampling, budget, po.jpeg_coding);
  po.jpeg_quality = fit.quality;
  po.encoded = std::move(fit.streams);  // the writer writes these instead of encoding again
  fit.streams.clear();
  return fit;
}

void write_page(const std::string& path, const std::vector<Image>& pages, size_t p, const PageWriteOptions& options) {
  if (options.encoded.empty()) {
    write_image(path, pages[p], options.format, options.jpeg_quality, options.jpeg_subsampling, options.jpeg_coding);
    return;
  }
  if (options.encoded.size() != pages.size())
    throw ImageError(path + ": " + std::to_string(options.encoded.size()) + " encoded pages for " +
                     std::to_string(pages.size()) + " pages");
  const std::vector<uint8_t>& bytes = options.encoded[p];
  // atomic as write_image's own writes are (temporary file beside it, then rename)
  write_file_atomic(path, {std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size())});
}

std::vector<uint8_t> encode_page(const std::vector<Image>& pages, size_t p, const PageWriteOptions& options) {
  if (!options.encoded.empty() && options.encoded.size() == pages.size()) return options.encoded[p];
  return encode_image(pages[p], options);
}

}  // namespace texdefrag
