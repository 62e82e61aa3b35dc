// A rolling-shutter colour camera (the Kinect v1's) exposes its rows one after another, top to
// bottom, line_time_us apart: while it turns, each row sees the scene from another orientation,
// and a pose fitted as for a global shutter errs most where the camera turns fastest. The
// pipeline rectifies each frame before anything uses it (odometry, detection, the streamed
// keyframe): both images as a global shutter would have seen them at the centre row's instant,
// with the camera's recent turn rate (first order: rotation only, constant over the frame).
//
//   RectifyRollingShutter(tracker, &bgr, &depth);  // after undistortion, before tracker.Track
#pragma once

#include <opencv2/core.hpp>

#include "client/tracking/frame_undistorter.h"
#include "client/tracking/tracker.h"
#include "common/camera.h"
#include "common/se3.h"
#include "common/tum_io.h"

namespace loci {

// w_cam_rad_s: the camera's angular velocity in its own frame, such that a point's coordinates
// t seconds after the centre row are exp([w t]x) times its coordinates at the centre row.
// line_s: time between two rows (> 0: rows exposed top to bottom). Both leave the image as it is
// for line_s 0 or a still camera.

// The colour image (CV_8UC3 or CV_8UC1): each output pixel is sampled (bilinearly) where its ray
// fell in the rolling shutter's image (the row it fell on sets when; fixed point, 2 steps).
cv::Mat RectifyColour(const cv::Mat& image, const PinholeCamera& cam, const Vec3d& w_cam_rad_s,
                      double line_s);
// The registered CV_16UC1 depth image: every pixel's 3-D point is turned to the centre row's
// camera and projected again (WarpDepthRows: the nearest wins, one-pixel cracks filled).
cv::Mat RectifyDepth(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& cam,
                     const Vec3d& w_cam_rad_s, double line_s);

// Both images of a frame, with the tracker's recent turn rate (Tracker::RecentTurnRate) and
// options().line_time_us; unchanged without either (the first frames, after a relocalisation).
void RectifyRollingShutter(const Tracker& tracker, cv::Mat* bgr, cv::Mat* depth_u16);

// The tracker measures its turn rate from its second frame on; its map starts at the first,
// which a fast camera would leave sheared. This seeds the tracker (Tracker::SeedTurnRate) with
// the turn rate over frames `first` and `first + 1` of seq, tracked unrectified by a throwaway
// tracker with the same options. Nothing for a global shutter, a shorter sequence, unreadable
// images or frames that do not track.
void SeedTurnRateFromSequence(const TumSequence& seq, size_t first,
                              const FrameUndistorter& undistort, Tracker* tracker);

}  // namespace loci
