// CLEAR-MOT-style counts for tracker tests where every detection's ground-truth object is
// known (each detection is a noisy copy of one object's box, or clutter).
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "common/detections_io.h"

namespace loci::detection {

struct MotCounts {
  int64_t gt = 0;             // ground-truth object instances over all frames
  int64_t misses = 0;         // GT instances without a reported id (dropped or still tentative)
  int64_t false_pos = 0;      // clutter detections that got an id
  int64_t id_switches = 0;    // a GT object's reported id differs from its previous one
  int64_t class_changes = 0;  // a track id reported with two classes (must stay 0)
  int64_t non_monotonic = 0;  // a new id not larger than every earlier id (must stay 0)
  std::map<int64_t, int64_t> last_id_of_gt;
  std::map<int64_t, std::string> class_of_id;
  int64_t max_id = 0;

  double Mota() const {
    return gt == 0 ? 0.0 : 1.0 - static_cast<double>(misses + false_pos + id_switches) / gt;
  }

  // gt_ids[i] = ground-truth object of dets[i] (0 = clutter); dropped = GT objects in view
  // whose detection was removed.
  void Add(const std::vector<Detection2D>& dets, const std::vector<int64_t>& gt_ids, int dropped) {
    gt += dropped;
    misses += dropped;
    for (size_t i = 0; i < dets.size(); ++i) {
      const int64_t h = dets[i].track_id;
      if (h != 0) {
        auto [it, inserted] = class_of_id.emplace(h, dets[i].class_name);
        if (!inserted && it->second != dets[i].class_name) ++class_changes;
        if (inserted) {
          if (h <= max_id) ++non_monotonic;
          max_id = std::max(max_id, h);
        }
      }
      if (gt_ids[i] == 0) {
        if (h != 0) ++false_pos;
        continue;
      }
      ++gt;
      if (h == 0) {
        ++misses;
        continue;
      }
      auto it = last_id_of_gt.find(gt_ids[i]);
      if (it != last_id_of_gt.end() && it->second != h) ++id_switches;
      last_id_of_gt[gt_ids[i]] = h;
    }
  }

  void Print(const char* label) const {
    std::printf(
        "[%s] GT %lld, misses %lld, FP %lld, ID switches %lld, ids %zu for %zu objects, "
        "MOTA %.3f\n",
        label, static_cast<long long>(gt), static_cast<long long>(misses),
        static_cast<long long>(false_pos), static_cast<long long>(id_switches), class_of_id.size(),
        last_id_of_gt.size(), Mota());
  }
};

}  // namespace loci::detection
