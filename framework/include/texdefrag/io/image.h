// Texture page images through OpenImageIO: 8-bit, 1-4 channels, rows top to bottom.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

struct ImageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;  ///< row-major, row 0 is the top of the image, channels interleaved

  uint8_t* at(int x, int y) { return &pixels[(static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * static_cast<size_t>(channels)]; }
  const uint8_t* at(int x, int y) const { return &pixels[(static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * static_cast<size_t>(channels)]; }
  bool empty() const { return pixels.empty(); }
};

/// Reads an image (JPEG, PNG, TIFF, anything OpenImageIO reads). Deeper formats are converted to
/// 8 bits. Throws ImageError naming the file.
/// Channels beyond the 4th are not read. Alpha is returned as stored (not premultiplied).
/// The first subimage / MIP level is read; EXIF orientation is not applied.
Image read_image(const std::string& path);

/// Reads only the header: width and height. Throws ImageError naming the file.
void read_image_size(const std::string& path, int& width, int& height);

enum class ImageFormat { Png, Jpeg };

/// JPEG chroma subsampling (horizontal:vertical sampling of Cb/Cr against Y). S444 keeps every
/// colour sample; S420 (libjpeg's default) halves both directions.
enum class JpegSubsampling { S444, S422, S420 };

/// "4:4:4", "4:2:2", "4:2:0" (the names of OpenImageIO's "jpeg:subsampling" attribute).
const char* jpeg_subsampling_name(JpegSubsampling s);

/// Writes an image atomically (temporary file, then rename). jpeg_quality in [1, 100].
/// path: must end in .png for Png, .jpg/.jpeg for Jpeg (else ImageError); its folder must exist.
/// image: 1-4 channels, pixels.size() == width*height*channels (else ImageError). JPEG stores 1 or
///        3 channels: the alpha of a 2- or 4-channel image is left out. PNG round-trips exactly.
/// subsampling: chroma subsampling of a 3-channel JPEG (ignored for PNG and grey JPEG); the default
///        is libjpeg's own (4:2:0); the pipeline's pages pass output.jpeg_subsampling (4:4:4).
/// Throws ImageError naming `path`; on failure no file and no temporary is left.
void write_image(const std::string& path, const Image& image, ImageFormat format, int jpeg_quality = 95,
                 JpegSubsampling subsampling = JpegSubsampling::S420);

}  // namespace texdefrag
