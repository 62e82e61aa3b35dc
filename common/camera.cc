#include "common/camera.h"

#include <algorithm>
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

Status LensDistortion::Validate(const PinholeCamera& camera) const {
  for (double c : {k1, k2, p1, p2, k3}) {
    if (!std::isfinite(c)) {
      return absl::InvalidArgumentError("distortion: coefficients must be finite");
    }
  }
  // The radius of the image's farthest corner in normalised coordinates, with a margin.
  const double du = std::max(camera.cx, camera.width_px - camera.cx) / camera.fx;
  const double dv = std::max(camera.cy, camera.height_px - camera.cy) / camera.fy;
  const double r_max = 1.2 * std::hypot(du, dv);
  constexpr int kSteps = 200;
  for (int i = 0; i <= kSteps; ++i) {
    const double r2 = std::pow(r_max * i / kSteps, 2);
    // d/dr of r (1 + k1 r^2 + k2 r^4 + k3 r^6): the distorted radius must keep growing.
    const double slope = 1 + 3 * k1 * r2 + 5 * k2 * r2 * r2 + 7 * k3 * r2 * r2 * r2;
    if (slope <= 0.05) {
      return absl::InvalidArgumentError(absl::StrCat(
          "distortion: the radial model folds over within the image (at normalised radius ",
          std::sqrt(r2), "); check the coefficients' order k1, k2, p1, p2, k3"));
    }
  }
  return absl::OkStatus();
}

}  // namespace loci
