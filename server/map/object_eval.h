// Object-map evaluation against ground truth (`loci eval objects`): count error |D - GT| / GT
// (paper 000 eq. 24), centroid errors after matching by class and nearest centroid, false
// positives and misses.
#pragma once

#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/objects_json.h"

namespace loci::server {

struct ObjectEvalOptions {
  double max_match_m = 0.3;  // a detection farther than this from every same-class GT is a FP
  // GT objects of these classes are evaluated; empty = all. Dynamic GT objects never are.
  std::vector<std::string> classes;
};

struct ObjectMatch {
  int64_t gt_id = 0;
  int64_t object_id = 0;
  std::string class_name;
  double centroid_error_m = 0;
};

struct ObjectEvalResult {
  int gt_count = 0;        // GT objects evaluated
  int detected_count = 0;  // map objects of the evaluated classes (D)
  double count_error = 0;  // |D - GT| / GT (0 when GT = 0 and D = 0)
  std::vector<ObjectMatch> matches;
  std::vector<int64_t> false_positive_ids;  // map objects without a GT partner
  std::vector<int64_t> missed_gt_ids;       // GT objects without a map partner
  double mean_centroid_error_m = 0;
  double max_centroid_error_m = 0;
};

// Greedy matching by increasing centroid distance among same-class pairs within max_match_m.
ObjectEvalResult EvaluateObjects(const std::vector<MapObject>& objects, const GroundTruthScene& gt,
                                 const ObjectEvalOptions& options);

}  // namespace loci::server
