#include "client/tracking/rolling_shutter.h"

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <vector>

#include "client/tracking/depth_time_warp.h"

namespace loci {

cv::Mat RectifyColour(const cv::Mat& image, const PinholeCamera& cam, const Vec3d& w_cam_rad_s,
                      double line_s) {
  if (line_s == 0 || w_cam_rad_s.isZero()) return image;
  cv::Mat map_u(image.size(), CV_32FC1), map_v(image.size(), CV_32FC1);
  for (int v = 0; v < image.rows; ++v) {
    float* mu = map_u.ptr<float>(v);
    float* mv = map_v.ptr<float>(v);
    for (int u = 0; u < image.cols; ++u) {
      const Vec3d ray((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
      double v_seen = v;
      Vec3d seen = ray;
      for (int i = 0; i < 2; ++i) {
        const double t_s = (v_seen - cam.cy) * line_s;
        seen = ray + t_s * w_cam_rad_s.cross(ray);  // first order: the turn is under a degree
        v_seen = cam.fy * seen.y() / seen.z() + cam.cy;
      }
      mu[u] = static_cast<float>(cam.fx * seen.x() / seen.z() + cam.cx);
      mv[u] = static_cast<float>(v_seen);
    }
  }
  cv::Mat out;
  cv::remap(image, out, map_u, map_v, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

cv::Mat RectifyDepth(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& cam,
                     const Vec3d& w_cam_rad_s, double line_s) {
  if (line_s == 0 || w_cam_rad_s.isZero()) return depth_u16;
  std::vector<SE3d> T_centre_row(static_cast<size_t>(depth_u16.rows), SE3d::Identity());
  for (int v = 0; v < depth_u16.rows; ++v) {
    const Vec3d turn = -w_cam_rad_s * ((v - cam.cy) * line_s);
    const double angle = turn.norm();
    if (angle > 0) T_centre_row[v].linear() = Eigen::AngleAxisd(angle, turn / angle).matrix();
  }
  return WarpDepthRows(depth_u16, depth_scale, cam, T_centre_row);
}

void RectifyRollingShutter(const Tracker& tracker, cv::Mat* bgr, cv::Mat* depth_u16) {
  const TrackerOptions& o = tracker.options();
  const std::optional<Vec3d> w_cam_rad_s = tracker.RecentTurnRate();
  if (o.line_time_us == 0 || !w_cam_rad_s) return;
  const double line_s = o.line_time_us * 1e-6;
  *bgr = RectifyColour(*bgr, o.camera, *w_cam_rad_s, line_s);
  *depth_u16 = RectifyDepth(*depth_u16, o.depth_scale, o.camera, *w_cam_rad_s, line_s);
}

void SeedTurnRateFromSequence(const TumSequence& seq, size_t first,
                              const FrameUndistorter& undistort, Tracker* tracker) {
  if (tracker->options().line_time_us == 0 || first + 1 >= seq.frames.size()) return;
  StatusOr<std::unique_ptr<Tracker>> probe = Tracker::Create(tracker->options());
  if (!probe.ok()) return;
  for (size_t i = first; i <= first + 1; ++i) {
    const TumFrame& f = seq.frames[i];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (bgr.empty() || depth.empty() || !undistort.Apply(&bgr, &depth).ok()) return;
    StatusOr<FrameResult> r = (*probe)->Track(bgr, depth, f.rgb_t_ns);
    if (!r.ok() || !r->tracked) return;
  }
  if (const std::optional<Vec3d> w = (*probe)->RecentTurnRate()) tracker->SeedTurnRate(*w);
}

}  // namespace loci
