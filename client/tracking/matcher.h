// Descriptor matching for the tracker: projection search of map points into a frame (guided by
// a pose), and brute-force matching of a frame against a keyframe (relocalisation).
#pragma once

#include <vector>

#include "client/tracking/local_map.h"
#include "client/tracking/orb_frame.h"

namespace loci {

struct PointMatch {
  int kp = -1;  // keypoint index in the frame
  MapPoint* point = nullptr;
  int distance = 0;      // Hamming bits
  bool inlier = false;   // after pose refinement
  bool dynamic = false;  // flagged by the dynamic test
};

struct ProjectionSearchParams {
  double radius_px = 12.0;  // at level 0, scaled by the predicted level's scale
  int max_hamming = 64;
  float ratio = 0.85f;
  int num_levels = 8;
  float scale_factor = 1.2f;
  bool count_visible = false;  // increments MapPoint::visible for points inside the image
};

// Projects `points` with T_cam_world into `frame` and matches each to the nearest-descriptor
// keypoint in a window; one map point per keypoint (the closer descriptor wins). Keypoints with
// kp_taken[kp] set are skipped and newly matched ones are set. Appends to *matches.
void SearchByProjection(const OrbFrame& frame, const SE3d& T_cam_world, const PinholeCamera& cam,
                        const std::vector<MapPoint*>& points, const ProjectionSearchParams& p,
                        int64_t frame_index, std::vector<char>* kp_taken,
                        std::vector<PointMatch>* matches);

// Brute-force matches of frame keypoints to keyframe keypoints with depth (best distance under
// max_hamming, ratio test). Returns pairs (frame kp, keyframe kp).
std::vector<std::pair<int, int>> MatchBruteForce(const OrbFrame& frame, const OrbFrame& keyframe,
                                                 int max_hamming, float ratio);

}  // namespace loci
