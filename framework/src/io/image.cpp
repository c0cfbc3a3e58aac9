// Texture page image IO (see texdefrag/io/image.h and docs/io.md "Images"): PNG and JPEG through
// libpng and libjpeg-turbo (image_png.cpp, image_jpeg.cpp), other formats through the OpenImageIO
// module loaded on first use (image_oiio.h).
#include "texdefrag/io/image.h"

#include "image_codec.h"
#include "image_oiio.h"
#include "texdefrag/util/paths.h"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

/// The OpenImageIO module, loaded once (and never unloaded) when a page of another format is met.
struct OiioModule {
  image_oiio::ReadFn read = nullptr;
  std::string file, error;
};

const OiioModule& oiio_module() {
  static const OiioModule m = [] {
    OiioModule r;
    r.file = (fs::path(install_root()) / "lib" / "texdefrag" / image_oiio::kModuleFile).string();
    void* h = dlopen(r.file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) {
      const char* e = dlerror();
      r.error = e ? e : "dlopen failed";
      return r;
    }
    r.read = reinterpret_cast<image_oiio::ReadFn>(dlsym(h, image_oiio::kReadSymbol));
    if (!r.read) r.error = r.file + ": no entry point " + image_oiio::kReadSymbol;
    return r;
  }();
  return m;
}

Image read_other_format(const std::string& path, bool header_only) {
  const OiioModule& m = oiio_module();
  if (!m.read)
    throw ImageError(path + ": not a PNG or JPEG file; other formats (TIFF, BMP, TGA, OpenEXR, ...) are read " +
                     "through OpenImageIO's module, which cannot be loaded: " + m.error);
  Image img;
  std::string error;
  if (!m.read(path.c_str(), header_only ? 1 : 0, &img, &error)) throw ImageError(path + ": " + error);
  return img;
}

Image read_file(const std::string& path, bool header_only) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw ImageError(path + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw ImageError(path + ": not a regular file");
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) throw ImageError(path + ": cannot open: " + std::strerror(errno));
  uint8_t head[8];
  const size_t n = std::fread(head, 1, sizeof head, f.get());
  if (n == 0) throw ImageError(path + ": cannot read image: the file is empty");
  std::rewind(f.get());
  image_codec::Source src;
  src.file = f.get();
  switch (image_codec::sniff(head, n)) {
    case image_codec::Kind::Png: return image_codec::read_png(src, path, header_only);
    case image_codec::Kind::Jpeg: return image_codec::read_jpeg(src, path, header_only);
    case image_codec::Kind::Other: break;
  }
  f.reset();
  return read_other_format(path, header_only);
}

std::string lower_extension(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

Image read_image(const std::string& path) { return read_file(path, false); }

void read_image_size(const std::string& path, int& width, int& height) {
  const Image img = read_file(path, true);
  width = img.width;
  height = img.height;
}

Image decode_image(const uint8_t* data, size_t size, const std::string& name, bool header_only) {
  image_codec::Source src;
  src.data = data;
  src.size = size;
  switch (image_codec::sniff(data, size)) {
    case image_codec::Kind::Png: return image_codec::read_png(src, name, header_only);
    case image_codec::Kind::Jpeg: return image_codec::read_jpeg(src, name, header_only);
    case image_codec::Kind::Other: break;
  }
  throw ImageError(name + ": not a PNG or JPEG image");
}

const char* jpeg_subsampling_name(JpegSubsampling s) {
  switch (s) {
    case JpegSubsampling::S444: return "4:4:4";
    case JpegSubsampling::S422: return "4:2:2";
    case JpegSubsampling::S420: return "4:2:0";
  }
  return "4:4:4";
}

const char* jpeg_tables_name(JpegTables t) { return t == JpegTables::Flat ? "flat" : "standard"; }

void write_image(const std::string& path, const Image& image, ImageFormat format, int jpeg_quality,
                 JpegSubsampling subsampling, JpegCoding coding) {
  if (image.width <= 0 || image.height <= 0)
    throw ImageError(path + ": cannot write an empty image (" + std::to_string(image.width) + "x" + std::to_string(image.height) + ")");
  if (image.channels < 1 || image.channels > 4)
    throw ImageError(path + ": cannot write an image with " + std::to_string(image.channels) + " channels (expected 1-4)");
  const size_t expected = static_cast<size_t>(image.width) * static_cast<size_t>(image.height) * static_cast<size_t>(image.channels);
  if (image.pixels.size() != expected)
    throw ImageError(path + ": pixel buffer holds " + std::to_string(image.pixels.size()) + " bytes, expected " + std::to_string(expected));
  if (format == ImageFormat::Jpeg && (jpeg_quality < 1 || jpeg_quality > 100))
    throw ImageError(path + ": JPEG quality " + std::to_string(jpeg_quality) + " outside [1, 100]");
  if (format == ImageFormat::Jpeg && (image.width > 65500 || image.height > 65500))
    throw ImageError(path + ": JPEG pages are at most 65500 texels wide and high (" + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + ")");

  const fs::path target(path);
  const std::string ext = lower_extension(target);
  const bool ext_ok = format == ImageFormat::Png ? ext == ".png" : (ext == ".jpg" || ext == ".jpeg");
  if (!ext_ok)
    throw ImageError(path + ": file extension does not match the format (expected " +
                     (format == ImageFormat::Png ? std::string(".png") : std::string(".jpg or .jpeg")) + ")");

  static std::atomic<unsigned> counter{0};
  const fs::path tmp = target.parent_path() / ("." + target.stem().string() + ".tmp-" + std::to_string(::getpid()) +
                                               "-" + std::to_string(counter++) + ext);
  std::error_code ec;
  File f(std::fopen(tmp.c_str(), "wb"));
  if (!f) throw ImageError(path + ": cannot create " + tmp.string() + ": " + std::strerror(errno));
  try {
    if (format == ImageFormat::Png)
      image_codec::write_png(f.get(), image, path);
    else
      image_codec::write_jpeg(f.get(), image, jpeg_quality, subsampling, path, coding);
  } catch (...) {
    f.reset();
    fs::remove(tmp, ec);
    throw;
  }
  const bool flushed = std::fflush(f.get()) == 0 && !std::ferror(f.get());
  const int flush_errno = errno;
  const bool closed = std::fclose(f.release()) == 0;
  if (!flushed || !closed) {
    const int e = flushed ? errno : flush_errno;
    fs::remove(tmp, ec);
    throw ImageError(path + ": write failed: " + std::strerror(e));
  }
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const int e = errno;
    fs::remove(tmp, ec);
    throw ImageError(path + ": cannot rename " + tmp.string() + " to it: " + std::strerror(e));
  }
}

}  // namespace texdefrag
