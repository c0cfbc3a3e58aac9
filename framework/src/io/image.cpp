// Texture page image IO through OpenImageIO (see texdefrag/io/image.h and docs/io.md).
#include "texdefrag/io/image.h"

#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

/// Captures what the C libraries under OpenImageIO print on stderr while it lives (libpng's default
/// error handler prints "libpng error: ..." before OpenImageIO reports the failure): the text goes
/// into our own message, naming the file, instead of a raw line on the terminal.
/// note: stderr is process-wide, so captures are serialised by a mutex (image reads are sequential in
/// the pipeline); while one is active, other threads' stderr output is captured too and dropped.
class StderrCapture {
 public:
  StderrCapture() : lock_(mutex()) {
    std::fflush(stderr);
    tmp_ = std::tmpfile();
    if (!tmp_) return;
    saved_ = ::dup(STDERR_FILENO);
    if (saved_ < 0 || ::dup2(::fileno(tmp_), STDERR_FILENO) < 0) restore();
  }
  ~StderrCapture() { restore(); }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  /// What was printed so far, on one line ("" when nothing), with libpng's prefix dropped.
  std::string text() {
    if (!tmp_) return {};
    std::fflush(stderr);
    std::string s;
    std::rewind(tmp_);
    char buf[512];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, tmp_)) > 0 && s.size() < 2000) s.append(buf, n);
    std::string out;
    size_t b = 0;
    while (b < s.size()) {
      size_t e = s.find('\n', b);
      if (e == std::string::npos) e = s.size();
      std::string line = s.substr(b, e - b);
      for (const char* prefix : {"libpng error: ", "libpng warning: "})
        if (line.rfind(prefix, 0) == 0) line = line.substr(std::strlen(prefix));
      if (!line.empty()) out += (out.empty() ? "" : "; ") + line;
      b = e + 1;
    }
    return out;
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  void restore() {
    if (saved_ >= 0) {
      std::fflush(stderr);
      ::dup2(saved_, STDERR_FILENO);
      ::close(saved_);
      saved_ = -1;
    }
    if (tmp_) {
      std::fclose(tmp_);
      tmp_ = nullptr;
    }
  }
  std::lock_guard<std::mutex> lock_;
  std::FILE* tmp_ = nullptr;
  int saved_ = -1;
};

/// " (the decoder said: ...)" when the capture holds text, else "".
std::string decoder_said(StderrCapture& cap) {
  const std::string t = cap.text();
  return t.empty() ? std::string() : " (the decoder said: " + t + ")";
}

/// Opens an image for reading or throws ImageError naming the file.
std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path, StderrCapture& cap) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw ImageError(path + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw ImageError(path + ": not a regular file");
  // note: OpenImageIO premultiplies alpha on reading by default, which would change colours of
  // partly transparent texels; ask for the stored (unassociated) values instead.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string why = OIIO::geterror();
    if (why.empty()) why = "unknown error";
    throw ImageError(path + ": cannot read image: " + why + decoder_said(cap));
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    throw ImageError(path + ": image has no pixels (" + std::to_string(spec.width) + "x" +
                     std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) + " channels)");
  if (spec.depth > 1) throw ImageError(path + ": volume images are not supported");
  return in;
}

std::string lower_extension(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

Image read_image(const std::string& path) {
  StderrCapture cap;
  auto in = open_input(path, cap);
  const OIIO::ImageSpec& spec = in->spec();
  Image img;
  img.width = spec.width;
  img.height = spec.height;
  // note: 1-4 channels are kept; further channels (e.g. extra TIFF samples) are not read.
  img.channels = std::min(spec.nchannels, 4);
  const size_t bytes = static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * static_cast<size_t>(img.channels);
  try {
    img.pixels.resize(bytes);
  } catch (const std::bad_alloc&) {
    throw ImageError(path + ": image too large to hold in memory (" + std::to_string(img.width) + "x" + std::to_string(img.height) + ")");
  }
  // OpenImageIO converts any pixel type to UINT8 (scaling 16-bit, clamping float to [0, 1]).
  if (!in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::UINT8, img.pixels.data())) {
    std::string why = in->geterror();
    throw ImageError(path + ": cannot read pixels: " + (why.empty() ? std::string("unknown error") : why) +
                     decoder_said(cap));
  }
  in->close();
  return img;
}

void read_image_size(const std::string& path, int& width, int& height) {
  StderrCapture cap;
  auto in = open_input(path, cap);
  width = in->spec().width;
  height = in->spec().height;
  in->close();
}

const char* jpeg_subsampling_name(JpegSubsampling s) {
  switch (s) {
    case JpegSubsampling::S444: return "4:4:4";
    case JpegSubsampling::S422: return "4:2:2";
    case JpegSubsampling::S420: return "4:2:0";
  }
  return "4:4:4";
}

namespace {

/// The JPEG encoder's settings: quality and chroma subsampling. Without "jpeg:subsampling"
/// OpenImageIO (libjpeg) writes 4:2:0, which loses half the colour resolution in each direction on
/// every write: on resampled atlas pages that cost up to 1.3 dB PSNR at quality 100 (docs/bench.md).
void set_jpeg_encoding(OIIO::ImageSpec& spec, int quality, JpegSubsampling subsampling) {
  spec.attribute("Compression", "jpeg:" + std::to_string(quality));
  spec.attribute("CompressionQuality", quality);
  spec.attribute("jpeg:subsampling", jpeg_subsampling_name(subsampling));
}

}  // namespace

void write_image(const std::string& path, const Image& image, ImageFormat format, int jpeg_quality,
                 JpegSubsampling subsampling) {
  if (image.width <= 0 || image.height <= 0)
    throw ImageError(path + ": cannot write an empty image (" + std::to_string(image.width) + "x" + std::to_string(image.height) + ")");
  if (image.channels < 1 || image.channels > 4)
    throw ImageError(path + ": cannot write an image with " + std::to_string(image.channels) + " channels (expected 1-4)");
  const size_t expected = static_cast<size_t>(image.width) * static_cast<size_t>(image.height) * static_cast<size_t>(image.channels);
  if (image.pixels.size() != expected)
    throw ImageError(path + ": pixel buffer holds " + std::to_string(image.pixels.size()) + " bytes, expected " + std::to_string(expected));
  if (format == ImageFormat::Jpeg && (jpeg_quality < 1 || jpeg_quality > 100))
    throw ImageError(path + ": JPEG quality " + std::to_string(jpeg_quality) + " outside [1, 100]");

  const fs::path target(path);
  const std::string ext = lower_extension(target);
  const bool ext_ok = format == ImageFormat::Png ? ext == ".png" : (ext == ".jpg" || ext == ".jpeg");
  if (!ext_ok)
    throw ImageError(path + ": file extension does not match the format (expected " +
                     (format == ImageFormat::Png ? std::string(".png") : std::string(".jpg or .jpeg")) + ")");

  // note: the temporary name keeps the format's extension, since OpenImageIO picks its writer by it.
  static std::atomic<unsigned> counter{0};
  const fs::path tmp = target.parent_path() / ("." + target.stem().string() + ".tmp-" + std::to_string(::getpid()) +
                                               "-" + std::to_string(counter++) + ext);
  auto out = OIIO::ImageOutput::create(tmp.string());
  if (!out) throw ImageError(path + ": no image writer for " + ext + ": " + OIIO::geterror());

  // JPEG stores 1 or 3 channels: an alpha channel (2 or 4 channels) is left out.
  int channels = image.channels;
  if (format == ImageFormat::Jpeg && (channels == 2 || channels == 4)) channels -= 1;
  OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::UINT8);
  if (channels == 2 || channels == 4) {
    spec.alpha_channel = channels - 1;
    spec.attribute("oiio:UnassociatedAlpha", 1);  // the pixels are not premultiplied: store as is
  }
  if (format == ImageFormat::Jpeg) set_jpeg_encoding(spec, jpeg_quality, subsampling);
  std::error_code ec;
  if (!out->open(tmp.string(), spec)) {
    const std::string why = out->geterror();
    fs::remove(tmp, ec);
    throw ImageError(path + ": cannot create " + tmp.string() + ": " + why);
  }
  const auto px = static_cast<OIIO::stride_t>(image.channels);
  const bool ok = out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data(), px, px * image.width);
  const std::string write_error = ok ? std::string() : out->geterror();
  const bool closed = out->close();
  const std::string close_error = closed ? std::string() : out->geterror();
  out.reset();
  if (!ok || !closed) {
    fs::remove(tmp, ec);
    throw ImageError(path + ": write failed: " + (ok ? close_error : write_error));
  }
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const int e = errno;
    fs::remove(tmp, ec);
    throw ImageError(path + ": cannot rename " + tmp.string() + " to it: " + std::strerror(e));
  }
}

}  // namespace texdefrag
