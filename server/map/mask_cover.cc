#include "server/map/mask_cover.h"

#include <algorithm>

namespace loci::server {

MaskCover CoverOf(const cv::Mat& labels, const cv::Rect& rect, int16_t label,
                  int16_t background_label) {
  const cv::Rect centre(rect.x + rect.width / 4, rect.y + rect.height / 4,
                        std::max(1, rect.width / 2), std::max(1, rect.height / 2));
  int free_whole = 0, own_whole = 0, free_centre = 0, own_centre = 0;
  for (int v = rect.y; v < rect.y + rect.height; ++v) {
    const int16_t* row = labels.ptr<int16_t>(v);
    const bool centre_row = v >= centre.y && v < centre.y + centre.height;
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const bool own = row[u] == label;
      if (!own && row[u] != background_label) continue;
      ++free_whole;
      own_whole += own;
      if (centre_row && u >= centre.x && u < centre.x + centre.width) {
        ++free_centre;
        own_centre += own;
      }
    }
  }
  MaskCover cover;
  if (free_centre > 0) cover.centre = static_cast<double>(own_centre) / free_centre;
  if (free_whole > 0) cover.whole = static_cast<double>(own_whole) / free_whole;
  return cover;
}

bool IsHollow(const MaskCover& cover, double min_centre_cover) {
  return cover.centre < min_centre_cover && cover.centre < cover.whole;
}

}  // namespace loci::server
