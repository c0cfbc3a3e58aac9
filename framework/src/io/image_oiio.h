// The optional OpenImageIO module for pages that are neither PNG nor JPEG (internal header of
// framework/src/io/image.cpp and image_oiio_module.cpp; docs/io.md "Images").
//
// OpenImageIO's dependency closure (OpenVDB, GDAL, ffmpeg, OpenCV, ...) costs 0.7 s CPU and about
// 125 MB RSS to load (docs/speed.md), so libtexdefrag does not link it: texdefrag_image_oiio.so
// in <root>/lib/texdefrag/ links it and is dlopen'ed the first time such a page is met.
#pragma once

#include "texdefrag/io/image.h"

#include <string>

namespace texdefrag::image_oiio {

/// The module's file name, in <root>/lib/texdefrag/ (texdefrag/util/paths.h).
constexpr const char* kModuleFile = "texdefrag_image_oiio.so";
/// Its one entry point, of type ReadFn.
constexpr const char* kReadSymbol = "texdefrag_image_oiio_read_v1";

/// Reads `path` through OpenImageIO as read_image did before (8 bits, 1-4 channels, alpha as
/// stored, first subimage). header_only: width, height, channels only. On failure returns false
/// with *error set to a message that does not start with the path.
using ReadFn = bool (*)(const char* path, int header_only, Image* out, std::string* error);

}  // namespace texdefrag::image_oiio
