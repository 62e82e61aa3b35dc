// A 256-bit binary descriptor (ORB) as four 64-bit words, and its Hamming distance.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>

namespace loci::place {

using Descriptor256 = std::array<uint64_t, 4>;

inline int Hamming(const Descriptor256& a, const Descriptor256& b) {
  return std::popcount(a[0] ^ b[0]) + std::popcount(a[1] ^ b[1]) + std::popcount(a[2] ^ b[2]) +
         std::popcount(a[3] ^ b[3]);
}

// Row `row` of a CV_8UC1 matrix with 32 columns.
inline Descriptor256 DescriptorRow(const cv::Mat& descriptors, int row) {
  Descriptor256 d;
  std::memcpy(d.data(), descriptors.ptr<uint8_t>(row), sizeof(d));
  return d;
}

}  // namespace loci::place
