// Consistency before a loop or merge is accepted, over at least 3 keyframes (ORB-SLAM3's Atlas
// confirms a merge on 3 keyframes, CCM-SLAM merges on one match and its users report distorted
// maps).
//
// A hypothesis names two frames whose relative transform T_x_y is to be found (for a merge:
// two robots' odometry frames; for a loop: a robot's drifted frame against itself). Each
// verified keyframe match gives one estimate of T_x_y (its T_a_b composed with the two
// keyframes' odometry poses). The gate accepts the hypothesis once min_matches estimates from
// distinct keyframes agree pairwise within max_translation_m and max_rotation_deg. An estimate
// that disagrees with those collected restarts the count from itself (a wrong match delays an
// acceptance, it never joins one). An accepted hypothesis starts over empty.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/se3.h"
#include "server/place/place_options.h"

namespace loci::place {

class ConsistencyGate {
 public:
  enum class Verdict {
    kPending,    // agrees with the collected estimates (or is the first); not enough of them yet
    kAccepted,   // the min_matches-th agreeing estimate: T_x_y is their consensus
    kDuplicate,  // a keyframe already counted for this hypothesis: ignored
    kReset,      // disagreed: the collected estimates were dropped, this one starts a new count
  };
  struct Decision {
    Verdict verdict = Verdict::kPending;
    int agreeing = 0;               // estimates collected, this one included
    SE3d T_x_y = SE3d::Identity();  // consensus when accepted: mean translation and rotation
  };

  explicit ConsistencyGate(const ConsistencyOptions& options) : options_(options) {}

  // Adds the estimate T_x_y of `hypothesis` from the match found for keyframe `keyframe_id`.
  Decision Add(const std::string& hypothesis, int64_t keyframe_id, const SE3d& T_x_y);
  // Estimates collected for a hypothesis (0 when none).
  int Pending(const std::string& hypothesis) const;
  void Clear(const std::string& hypothesis) { pending_.erase(hypothesis); }
  // Whether two estimates agree within max_translation_m and max_rotation_deg.
  bool Agree(const SE3d& a, const SE3d& b) const;

 private:
  struct Estimate {
    int64_t keyframe_id;
    SE3d T_x_y;
  };

  ConsistencyOptions options_;
  std::map<std::string, std::vector<Estimate>> pending_;
};

// Mean of rigid transforms close to each other: mean translation, rotation from the normalised
// mean of sign-aligned quaternions.
SE3d MeanTransform(const std::vector<SE3d>& transforms);

}  // namespace loci::place
