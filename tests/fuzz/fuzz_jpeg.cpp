// libFuzzer target for the JPEG reader (framework/src/io/image_jpeg.cpp) and the JPEG writer on what
// it decodes; the properties are in fuzz_image.h. Build: CXX=clang++ cmake -DTEXDEFRAG_FUZZ=ON ...;
// run: fuzz_jpeg tests/fuzz/corpus_jpeg.
#include "fuzz_image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return texdefrag::fuzz::run_image_input("fuzz_jpeg", true, data, size);
}
