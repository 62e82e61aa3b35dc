#include "common/camera.h"

#include <cmath>

namespace loci {

Status PinholeCamera::Validate() const {
  const bool finite = std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
                      std::isfinite(cy);
  if (!finite || fx <= 0 || fy <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics: focal lengths must be positive and finite (fx=", fx,
                     ", fy=", fy, ")"));
  }
  if (width_px <= 0 || height_px <= 0 || width_px > 8192 || height_px > 8192) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics: image size ", width_px, "x",
                                                   height_px, " outside 1..8192"));
  }
  if (cx < 0 || cy < 0 || cx > width_px || cy > height_px) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics: principal point (", cx, ", ", cy,
                                                   ") outside the image"));
  }
  return absl::OkStatus();
}

}  // namespace loci
