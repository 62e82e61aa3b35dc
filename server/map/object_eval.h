// Object-map evaluation against ground truth (`loci eval objects`, `loci bench report`): per
// class, map objects and ground-truth objects are matched with the Hungarian method on centroid
// distance within a radius; precision, recall, F1, the count error |D - GT| / GT (paper 000
// eq. 24) and centroid errors follow.
//
// Fair use of hand-made ground truth (objects_gt.md): only `high` and `medium` objects count for
// recall and the count error; a map object matched to a `low` one is neither right nor wrong. A
// map object is compared with the nearer of a ground-truth object's centroid and the centre of
// its visible part, when given.
#pragma once

#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/objects_json.h"

namespace loci::server {

struct ObjectEvalOptions {
  double max_match_m = 0.3;  // matching radius, m (0.3)
  // Extra radius for `low` ground-truth objects, whose positions objects_gt.md gives only to
  // +-0.2 m (0.2). A map object within it is neutral, not a false positive.
  double low_tolerance_m = 0.2;
  // Classes evaluated (map objects and ground truth); empty = all. Dynamic GT objects never are.
  std::vector<std::string> classes;
};

struct ObjectMatch {
  int64_t gt_id = 0;
  std::string gt_name;
  int64_t object_id = 0;
  std::string class_name;
  double centroid_error_m = 0;
  // Map centroid minus the ground-truth point it was compared with, world frame, m.
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();
  bool neutral = false;  // matched to a `low` ground-truth object: not counted
};

struct ClassEval {
  std::string class_name;
  int gt = 0;       // high + medium ground-truth objects
  int gt_low = 0;   // low ones (not counted)
  int mapped = 0;   // map objects of the class
  int tp = 0, fp = 0, fn = 0, neutral = 0;
};

struct ObjectEvalResult {
  int gt_count = 0;        // high + medium GT objects evaluated
  int detected_count = 0;  // D: map objects evaluated, minus those matched to low GT objects
  double count_error = 0;  // |D - GT| / GT (0 when GT = 0 and D = 0)
  int true_positives = 0;
  double precision = 0, recall = 0, f1 = 0;
  std::vector<ObjectMatch> matches;         // true positives and neutral matches
  std::vector<int64_t> false_positive_ids;  // map objects without a GT partner
  std::vector<int64_t> missed_gt_ids;       // high/medium GT objects without a map partner
  std::vector<std::string> missed_gt_names;
  std::vector<ClassEval> classes;           // sorted by class name
  double mean_centroid_error_m = 0;         // over true positives
  double median_centroid_error_m = 0;
  double max_centroid_error_m = 0;
};

// `objects` must already be in the ground truth's world frame.
ObjectEvalResult EvaluateObjects(const std::vector<MapObject>& objects, const GroundTruthScene& gt,
                                 const ObjectEvalOptions& options);

}  // namespace loci::server
