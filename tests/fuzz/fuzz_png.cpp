// libFuzzer target for the PNG reader (framework/src/io/image_png.cpp) and the PNG writer on what
// it decodes; the properties are in fuzz_image.h. Build: CXX=clang++ cmake -DTEXDEFRAG_FUZZ=ON ...;
// run: fuzz_png tests/fuzz/corpus_png.
#include "fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return texdefrag::fuzz::run_image_input("fuzz_png", false, data, size);
}
