// Shared body of the libFuzzer targets for the PNG and JPEG readers (fuzz_png.cpp, fuzz_jpeg.cpp;
// docs/io.md "Fuzzing").
//
// Properties checked on every input:
// - decode_image (header, then pixels) either succeeds or throws ImageError whose message starts
//   with the name it was given; anything else, a crash, a leak, a hang or undefined behaviour is a
//   finding (the targets are built with AddressSanitizer and UBSan);
// - a decoded image has 1-4 channels (JPEG: 1 or 3), the header's size, and width*height*channels
//   pixel bytes;
// - small decoded images go through write_image and read_image: PNG gives the same pixels back,
//   JPEG the same size and channels.
// Headers declaring more than 2^24 pixel bytes are not decoded (the fuzzer's memory limit).
#pragma once

#include "texdefrag/io/image.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace texdefrag::fuzz {

[[noreturn]] inline void finding(const char* target, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", target, what.c_str());
  std::abort();
}

inline const std::filesystem::path& work_dir(const char* target) {
  static const std::filesystem::path dir = [target] {
    std::filesystem::path d = std::filesystem::temp_directory_path() / (std::string("texdefrag-") + target + "-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline int run_image_input(const char* target, bool jpeg, const uint8_t* data, size_t size) {
  const std::string name = jpeg ? "input.jpg" : "input.png";
  Image head, img;
  try {
    head = decode_image(data, size, name, true);
    if (head.width <= 0 || head.height <= 0 || head.channels < 1 || head.channels > 4 || !head.pixels.empty())
      finding(target, "bad header result");
    if (static_cast<double>(head.width) * head.height * head.channels > double(1 << 24)) return 0;
    img = decode_image(data, size, name);
  } catch (const ImageError& e) {
    if (std::string(e.what()).rfind(name + ": ", 0) != 0) finding(target, std::string("error without the name: ") + e.what());
    return 0;
  }
  if (img.width != head.width || img.height != head.height || img.channels != head.channels)
    finding(target, "header and pixels disagree");
  if (jpeg && img.channels != 1 && img.channels != 3) finding(target, "JPEG with " + std::to_string(img.channels) + " channels");
  if (img.pixels.size() != static_cast<size_t>(img.width) * img.height * img.channels) finding(target, "pixel buffer size");
  if (static_cast<size_t>(img.width) * img.height > 4096) return 0;
  const std::string out = (work_dir(target) / (jpeg ? "out.jpg" : "out.png")).string();
  try {
    write_image(out, img, jpeg ? ImageFormat::Jpeg : ImageFormat::Png, 90);
    const Image back = read_image(out);
    if (back.width != img.width || back.height != img.height || back.channels != img.channels)
      finding(target, "written image reads back with another size");
    if (!jpeg && back.pixels != img.pixels) finding(target, "PNG round trip changed pixels");
  } catch (const ImageError& e) {
    finding(target, std::string("cannot write or read back a decoded image: ") + e.what());
  }
  return 0;
}

}  // namespace texdefrag::fuzz
