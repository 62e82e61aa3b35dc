// What an encoded image claims to be, read from its first bytes without decoding it: format by
// magic bytes, declared size, and whether the stream ends where its format says it must. Lets
// a server refuse a 600-byte JPEG that claims 32000 x 32000 pixels before allocating anything.
#pragma once

#include <string_view>

#include "common/status.h"

namespace loci {

enum class ImageFormat { kJpeg, kPng };

struct ImageHeader {
  ImageFormat format = ImageFormat::kJpeg;
  int width_px = 0;
  int height_px = 0;
  int channels = 0;   // JPEG components; PNG: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA, palette 1
  int bit_depth = 0;  // bits per sample
  bool complete = false;  // JPEG ends with EOI, PNG with an IEND chunk
};

// Reads the header of JPEG or PNG bytes. InvalidArgument for anything else, a header that is
// cut short, or a declared size of 0.
StatusOr<ImageHeader> ReadImageHeader(std::string_view bytes);

// Largest image any decoder in loci accepts when the caller expects no particular size: 16.7
// megapixels (4096 x 4096).
inline constexpr long long kMaxDecodePixels = 4096LL * 4096LL;

// Checks a header before decoding: the expected format, a complete stream, the expected size
// (when expected_* > 0) and at most kMaxDecodePixels. `what` names the field in the error.
Status CheckImageHeader(const ImageHeader& h, ImageFormat format, int expected_width,
                        int expected_height, const char* what);

}  // namespace loci
