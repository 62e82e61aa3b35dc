// loci::WarpDepth: a depth image moved to another camera pose. An RGB-D sensor whose depth and
// colour cameras are not triggered together (the Kinect v1: TUM's depth stamps lie up to 20 ms
// from the colour stamps, 10.7 ms on average in fr1_rpy) captures its depth from where the
// camera was at the depth stamp; at fr1_rpy's 50-140 deg/s that is 0.5-3 deg away from where it
// was at the colour stamp. The tracker's constant-velocity motion between the two stamps
// (Tracker::PredictedMotion) can move the depth to the colour image's instant before anything
// uses the two together (odometry, object masks, the streamed keyframe). The pipeline does so
// only with tracker.align_depth_time, off by default: on fr1_rpy it did not help (client
// README).
//
//   AlignDepthToColourTime(tracker, f.depth_t_ns, f.rgb_t_ns, &depth);  // before tracker.Track
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "client/tracking/tracker.h"
#include "common/camera.h"
#include "common/se3.h"

namespace loci {

// The CV_16UC1 depth image (depth_scale units per metre) as seen from the pose T_new_old
// (p_new = T_new_old * p_old): each pixel is back-projected with `camera`, moved and projected
// again. Where several land on one pixel the nearest wins; a one-pixel crack between two
// neighbours that agree within 2 % gets their mean; pixels nothing lands on have no depth (0).
cv::Mat WarpDepth(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& camera,
                  const SE3d& T_new_old);
// The same with one pose per image row (T_new_old_per_row[v] moves row v's points; a rolling
// shutter's rows are seen from different poses); an empty image when the count is not the
// image's rows.
cv::Mat WarpDepthRows(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& camera,
                      const std::vector<SE3d>& T_new_old_per_row);

// Fills pixels without depth whose two neighbours along one axis have depths within 2 % of each
// other: the one-pixel cracks a forward warp leaves where it stretches the image.
void FillDepthCracks(cv::Mat* depth_u16);

// Moves *depth_u16, captured at depth_t_ns, to rgb_t_ns with the tracker's predicted motion
// (Tracker::PredictedMotion) when options().align_depth_time is set and the stamps differ.
// Unchanged before the tracker has a motion model (the first frames, after a relocalisation),
// and for stamps further apart than one frame interval.
void AlignDepthToColourTime(const Tracker& tracker, int64_t depth_t_ns, int64_t rgb_t_ns,
                            cv::Mat* depth_u16);

}  // namespace loci
