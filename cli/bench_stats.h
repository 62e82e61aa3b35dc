// Summary figures the `loci bench` commands print.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace loci::cli {

// The q-quantile (q in [0, 1]) of `v` by nearest rank, rounding q * (n - 1): 0.5 is the median
// (the upper middle for an even count), 1.0 the maximum. 0 for an empty vector.
inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1,
                    static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

}  // namespace loci::cli
