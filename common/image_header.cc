#include "common/image_header.h"

#include <cstdint>

namespace loci {
namespace {

Status Invalid(const std::string& msg) { return absl::InvalidArgumentError(msg); }

uint32_t Be16(std::string_view b, size_t i) {
  return (static_cast<uint8_t>(b[i]) << 8) | static_cast<uint8_t>(b[i + 1]);
}

uint32_t Be32(std::string_view b, size_t i) { return (Be16(b, i) << 16) | Be16(b, i + 2); }

bool IsStartOfFrame(uint8_t marker) {
  // SOF0-SOF15 except DHT (C4), JPG (C8) and DAC (CC).
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

// True when the last bytes (encoders may pad a little) hold the EOI marker.
bool EndsWithEoi(std::string_view b) {
  const size_t from = b.size() > 32 ? b.size() - 32 : 0;
  return b.substr(from).find("\xFF\xD9") != std::string_view::npos;
}

StatusOr<ImageHeader> ReadJpeg(std::string_view b) {
  size_t i = 2;  // after SOI
  while (i + 4 <= b.size()) {
    if (static_cast<uint8_t>(b[i]) != 0xFF) return Invalid("JPEG: no marker where one must be");
    const uint8_t marker = static_cast<uint8_t>(b[i + 1]);
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    const uint32_t len = Be16(b, i + 2);
    if (len < 2) return Invalid("JPEG: segment length below 2");
    if (IsStartOfFrame(marker)) {
      if (i + 10 > b.size()) break;
      ImageHeader h;
      h.format = ImageFormat::kJpeg;
      h.bit_depth = static_cast<uint8_t>(b[i + 4]);
      h.height_px = static_cast<int>(Be16(b, i + 5));
      h.width_px = static_cast<int>(Be16(b, i + 7));
      h.channels = static_cast<uint8_t>(b[i + 9]);
      h.complete = EndsWithEoi(b);
      return h;
    }
    if (marker == 0xDA) return Invalid("JPEG: scan data before any frame header");
    i += 2 + len;
  }
  return Invalid("JPEG: cut short before its frame header");
}

StatusOr<ImageHeader> ReadPng(std::string_view b) {
  // Signature (8), IHDR length (4) and type (4), width, height, bit depth, colour type.
  if (b.size() < 26 || b.substr(12, 4) != "IHDR") return Invalid("PNG: no IHDR chunk");
  ImageHeader h;
  h.format = ImageFormat::kPng;
  h.width_px = static_cast<int>(std::min<uint32_t>(Be32(b, 16), 1u << 30));
  h.height_px = static_cast<int>(std::min<uint32_t>(Be32(b, 20), 1u << 30));
  h.bit_depth = static_cast<uint8_t>(b[24]);
  switch (static_cast<uint8_t>(b[25])) {
    case 0: h.channels = 1; break;  // grey
    case 2: h.channels = 3; break;  // RGB
    case 3: h.channels = 1; break;  // palette
    case 4: h.channels = 2; break;  // grey + alpha
    case 6: h.channels = 4; break;  // RGBA
    default: return Invalid("PNG: unknown colour type");
  }
  // The last chunk: length 0, "IEND", CRC.
  h.complete = b.size() >= 12 && b.substr(b.size() - 8, 4) == "IEND";
  return h;
}

}  // namespace

StatusOr<ImageHeader> ReadImageHeader(std::string_view b) {
  if (b.empty()) return Invalid("empty image");
  StatusOr<ImageHeader> h = Invalid("neither JPEG nor PNG (unknown magic bytes)");
  if (b.size() >= 3 && b.substr(0, 3) == "\xFF\xD8\xFF") {
    h = ReadJpeg(b);
  } else if (b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8)) {
    h = ReadPng(b);
  }
  if (h.ok() && (h->width_px <= 0 || h->height_px <= 0)) return Invalid("declared size is 0");
  return h;
}

Status CheckImageHeader(const ImageHeader& h, ImageFormat format, int expected_width,
                        int expected_height, const char* what) {
  const char* want = format == ImageFormat::kJpeg ? "JPEG" : "PNG";
  if (h.format != format) {
    return Invalid(absl::StrCat(what, ": expected ", want, ", got ",
                                h.format == ImageFormat::kJpeg ? "JPEG" : "PNG"));
  }
  if ((expected_width > 0 && h.width_px != expected_width) ||
      (expected_height > 0 && h.height_px != expected_height)) {
    return Invalid(absl::StrCat(what, ": declared size ", h.width_px, "x", h.height_px,
                                " differs from the expected ", expected_width, "x",
                                expected_height));
  }
  if (static_cast<long long>(h.width_px) * h.height_px > kMaxDecodePixels) {
    return Invalid(absl::StrCat(what, ": declared size ", h.width_px, "x", h.height_px,
                                " exceeds ", kMaxDecodePixels, " pixels"));
  }
  if (!h.complete) {
    return Invalid(absl::StrCat(what, ": truncated (the ", want, " stream has no end marker)"));
  }
  return absl::OkStatus();
}

}  // namespace loci
