// A 256-bit binary descriptor (ORB) as four 64-bit words, and its Hamming distance.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <vector>

// A function marked with this is compiled twice, with the POPCNT instruction and without, and
// picked at load time (glibc ifunc): std::popcount is one instruction with it and a libgcc call
// without, and Debian's amd64 baseline does not guarantee it. Not in a ThreadSanitizer build:
// GCC instruments the ifunc resolver with __tsan_func_entry, and the resolver runs while the
// dynamic loader relocates the binary, before the TSan runtime is set up, so every binary
// holding such a function crashed at load (docs/sanitizers.md). Only on x86-64.
#if defined(__SANITIZE_THREAD__) || !defined(__x86_64__)
#define LOCI_POPCNT_CLONES
#else
#define LOCI_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#endif

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

// The nearest and second-nearest row of `train` to each row of `query` (both CV_8UC1 with 32
// columns), brute force, as cv::BFMatcher(NORM_HAMMING).knnMatch with k = 2 finds them (about
// a third of its CPU). When two train rows are equally near, `index` is the first of them; the
// ratio test drops such a match whichever it is, since best == second.
struct TwoNearest {
  int index = -1;    // row of train nearest; -1 when train is empty
  int best = 257;    // its Hamming distance (257: none)
  int second = 257;  // the second-nearest row's distance (257: fewer than 2 rows)
};
std::vector<TwoNearest> TwoNearestRows(const cv::Mat& query, const cv::Mat& train);

}  // namespace loci::place
