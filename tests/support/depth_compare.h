// Comparing two depth images in tests (client tests of depth warps and rectification).
#pragma once

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>

namespace loci::testing {

// Share of the pixels with depth in both CV_16UC1 images whose depths agree within 1 %.
inline double AgreeingDepthShare(const cv::Mat& a_u16, const cv::Mat& b_u16) {
  int both = 0, agree = 0;
  for (int v = 0; v < a_u16.rows; ++v) {
    for (int u = 0; u < a_u16.cols; ++u) {
      const int a = a_u16.at<uint16_t>(v, u), b = b_u16.at<uint16_t>(v, u);
      if (a == 0 || b == 0) continue;
      ++both;
      agree += std::abs(a - b) <= 0.01 * b;
    }
  }
  return both > 0 ? static_cast<double>(agree) / both : 0.0;
}

}  // namespace loci::testing
