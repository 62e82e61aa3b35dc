// Evaluation of a map against real ground truth (`loci eval objects`, `loci bench report`): the
// map frame is aligned to the ground-truth world frame with the keyframe trajectory (rigid Horn
// alignment, as the TUM ATE tool does), objects are scored with server::EvaluateObjects, and
// every ground-truth "X on Y" pair is asked through the server's own Ask.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/objects_json.h"
#include "common/status.h"
#include "common/trajectory_eval.h"
#include "common/tum_io.h"
#include "loci/v1/query.pb.h"
#include "server/map/object_eval.h"

namespace loci::report {

// One "where is the X on the Y" question and whether the answer was right: it names the map
// object matched to X with an "on" relation to the map object matched to Y.
struct OnPairCheck {
  std::string gt_subject, gt_support;  // ground-truth names
  std::string question, answer;
  int64_t subject_id = 0, support_id = 0;  // matched map objects (0 = not matched)
  bool right = false;
};

struct GroundTruthEval {
  AteResult alignment;  // keyframe trajectory vs groundtruth.txt; T_gt_est maps map -> world
  server::ObjectEvalResult objects;
  std::vector<MapObject> objects_world;  // the evaluated objects, centroids in the world frame
  std::vector<OnPairCheck> on_pairs;
  int on_right = 0;
  double on_share = 0;  // on_right / on_pairs.size() (0 when none)
  double radius_m = 0;  // the matching radius used
  double low_tolerance_m = 0;  // its extra for `low` ground-truth objects
  // Angle between the map's +z, carried into the world by the alignment, and the ground
  // truth's up (deg): how level the map frame is.
  double up_error_deg = 0;
  // The same angle with the rotation taken from the camera orientations instead
  // (OrientationAlignment), and the angle between the two alignments' rotations. A large
  // disagreement means the trajectory barely translates and the position alignment turns the
  // map by itself: centroid errors then include that turn.
  double up_error_orientation_deg = 0;
  double alignment_disagreement_deg = 0;
  bool aligned_by_orientations = false;  // GroundTruthEvalInput::align_by_orientations
};

struct GroundTruthEvalInput {
  std::vector<MapObject> objects;  // map frame, confirmed
  std::vector<Trajectory> keyframes;  // map frame, one per robot (all stacked for alignment)
  Trajectory groundtruth;             // world frame
  GroundTruthScene gt;
  server::ObjectEvalOptions options;
  // false: the TUM way (ComputeAte: positions only). true: AlignByOrientations (the rotation
  // from the camera orientations), for sequences that turn in place.
  bool align_by_orientations = false;
  // Asks the map a question (gRPC or in process); null = no X-on-Y check.
  std::function<loci::v1::AskResponse(const std::string&)> ask;
};

StatusOr<GroundTruthEval> EvaluateAgainstGroundTruth(const GroundTruthEvalInput& in);

// Human-readable report (per-class rows, totals, X-on-Y answers).
std::string FormatGroundTruthEval(const GroundTruthEval& e);

}  // namespace loci::report
