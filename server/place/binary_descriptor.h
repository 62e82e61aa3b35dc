// ORB descriptors (common/hamming.h) read from OpenCV matrices, and brute-force matching.
#pragma once

#include <cstring>
#include <opencv2/core.hpp>
#include <vector>

#include "common/hamming.h"

namespace loci::place {

// Row `row` of a CV_8UC1 matrix with 32 columns.
inline Descriptor256 DescriptorRow(const cv::Mat& descriptors, int row) {
  Descriptor256 d;
  std::memcpy(d.data(), descriptors.ptr<uint8_t>(row), sizeof(d));
  return d;
}

// The nearest and second-nearest row of `train` to each row of `query` (both CV_8UC1 with 32
// columns), brute force, as cv::BFMatcher(NORM_HAMMING).knnMatch with k = 2 finds them (with it,
// verifying a pair of real keyframes took 5.7 ms of CPU, against 24.0 ms). When two train rows
// are equally near, `index` is the first of them; the ratio test drops such a match whichever it
// is, since best == second.
struct TwoNearest {
  int index = -1;    // row of train nearest; -1 when train is empty
  int best = 257;    // its Hamming distance (257: none)
  int second = 257;  // the second-nearest row's distance (257: fewer than 2 rows)
};
std::vector<TwoNearest> TwoNearestRows(const cv::Mat& query, const cv::Mat& train);

}  // namespace loci::place
