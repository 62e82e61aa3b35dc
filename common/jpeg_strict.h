// JPEG decoding with libjpeg(-turbo), where every warning is an error: libjpeg "decodes" a
// bit-flipped or truncated stream with a warning and grey or garbled blocks, which a map must
// not store as a camera image.
#pragma once

#include <string_view>

#include <opencv2/core.hpp>

#include "common/status.h"

namespace loci {

// Decodes JPEG bytes to 8-bit BGR (CV_8UC3). InvalidArgument with libjpeg's message on any error
// or warning ("Corrupt JPEG data: ...").
StatusOr<cv::Mat> DecodeJpegStrict(std::string_view bytes);

}  // namespace loci
