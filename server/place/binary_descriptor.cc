#include "server/place/binary_descriptor.h"

namespace loci::place {

LOCI_POPCNT_CLONES std::vector<TwoNearest> TwoNearestRows(const cv::Mat& query,
                                                          const cv::Mat& train) {
  std::vector<Descriptor256> rows(static_cast<size_t>(train.rows));
  for (int j = 0; j < train.rows; ++j) rows[j] = DescriptorRow(train, j);
  std::vector<TwoNearest> out(static_cast<size_t>(query.rows));
  for (int i = 0; i < query.rows; ++i) {
    const Descriptor256 d = DescriptorRow(query, i);
    TwoNearest& n = out[i];
    for (size_t j = 0; j < rows.size(); ++j) {
      const int h = Hamming(d, rows[j]);
      if (h >= n.second) continue;
      if (h < n.best) {
        n.second = n.best;
        n.best = h;
        n.index = static_cast<int>(j);
      } else {
        n.second = h;
      }
    }
  }
  return out;
}

}  // namespace loci::place
