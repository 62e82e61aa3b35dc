// libFuzzer target: the image header reader and the keyframe image decoders (JPEG colour,
// 16-bit PNG depth, PNG masks) on arbitrary bytes. Any crash, leak or sanitizer report fails.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "common/image_codec.h"
#include "common/image_header.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  (void)loci::ReadImageHeader(bytes);
  (void)loci::DecodeJpeg(bytes, 64, 48);
  (void)loci::DecodeDepthPng(bytes, 64, 48);
  (void)loci::DecodeMaskPng(bytes, 65, 49);
  return 0;
}
