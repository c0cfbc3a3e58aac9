// texdefrag_image_oiio.so: pages in formats other than PNG and JPEG (TIFF, BMP, TGA, OpenEXR,
// WebP, ...) through OpenImageIO, loaded by image.cpp only when such a page is met (image_oiio.h).
// The reading is what read_image did for every format before PNG and JPEG had their own codecs.
#include "image_oiio.h"

#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <type_traits>

namespace {

using texdefrag::Image;

/// Captures what the C libraries under OpenImageIO print on stderr while it lives (libtiff's
/// warnings, libpng's "libpng error: ..."): the text goes into our own message instead of a raw line
/// on the terminal.
/// note: stderr is process-wide, so captures are serialised by a mutex; while one is active, other
/// threads' stderr output is captured too and dropped.
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

bool read(const std::string& path, bool header_only, Image& img, std::string& error) {
  StderrCapture cap;
  // note: OpenImageIO premultiplies alpha on reading by default, which would change colours of
  // partly transparent texels; ask for the stored (unassociated) values instead.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string why = OIIO::geterror();
    if (why.empty()) why = "unknown error";
    error = "cannot read image: " + why + decoder_said(cap);
    return false;
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    error = "image has no pixels (" + std::to_string(spec.width) + "x" + std::to_string(spec.height) + ", " +
            std::to_string(spec.nchannels) + " channels)";
    return false;
  }
  if (spec.depth > 1) {
    error = "volume images are not supported";
    return false;
  }
  img.width = spec.width;
  img.height = spec.height;
  // note: 1-4 channels are kept; further channels (e.g. extra TIFF samples) are not read.
  img.channels = std::min(spec.nchannels, 4);
  if (header_only) return true;
  try {
    img.pixels.resize(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * static_cast<size_t>(img.channels));
  } catch (const std::exception&) {
    error = "image too large to hold in memory (" + std::to_string(img.width) + "x" + std::to_string(img.height) + ")";
    return false;
  }
  // OpenImageIO converts any pixel type to UINT8 (scaling 16-bit, clamping float to [0, 1]).
  if (!in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::UINT8, img.pixels.data())) {
    const std::string why = in->geterror();
    error = "cannot read pixels: " + (why.empty() ? std::string("unknown error") : why) + decoder_said(cap);
    return false;
  }
  in->close();
  return true;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) bool texdefrag_image_oiio_read_v1(const char* path, int header_only,
                                                                                    Image* out, std::string* error) {
  try {
    return read(path, header_only != 0, *out, *error);
  } catch (const std::exception& e) {  // nothing may cross the module boundary as an exception
    *error = std::string("cannot read image: ") + e.what();
    return false;
  }
}

// The entry point must match image_oiio.h's ReadFn.
static_assert(std::is_same_v<decltype(&texdefrag_image_oiio_read_v1), texdefrag::image_oiio::ReadFn>);
