#include "tests/place/tum_keyframes.h"

#include <filesystem>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <span>

#include "common/config.h"
#include "common/image_codec.h"
#include "common/time.h"
#include "common/tum_io.h"
#include "tests/support/tum_data.h"

namespace loci::place::testing {
namespace {

constexpr double kTumDepthScale = 5000.0;
constexpr int64_t kMaxGtDtNs = 10'000'000;

double SpeedDegS(const Trajectory& gt, int64_t t_ns) {
  constexpr int64_t kHalfNs = 50'000'000;
  const StampedPose* a =
      NearestByTime(std::span<const StampedPose>(gt), t_ns - kHalfNs, kMaxGtDtNs);
  const StampedPose* b =
      NearestByTime(std::span<const StampedPose>(gt), t_ns + kHalfNs, kMaxGtDtNs);
  if (!a || !b || a == b) return -1;
  const double dt_s = NsToSeconds(b->t_ns - a->t_ns);
  return RotationAngleRad(a->T_world_cam.inverse() * b->T_world_cam) * 180.0 / std::numbers::pi /
         dt_s;
}

}  // namespace

StatusOr<std::vector<TumKeyframe>> LoadTumKeyframes(const std::string& dir, int stride,
                                                    int max_frames, const FeatureOptions& options,
                                                    bool keep_images) {
  LOCI_ASSIGN_OR_RETURN(const TumSequence seq, LoadTumSequence(dir));
  std::vector<TumKeyframe> out;
  const PinholeCamera camera = PinholeCamera::TumFr1();
  for (size_t i = 0; i < seq.frames.size(); i += static_cast<size_t>(stride)) {
    if (max_frames > 0 && static_cast<int>(out.size()) >= max_frames) break;
    const TumFrame& f = seq.frames[i];
    TumKeyframe kf;
    kf.index = static_cast<int>(i);
    kf.t_ns = f.rgb_t_ns;
    kf.bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    const cv::Mat depth_u16 = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (kf.bgr.empty() || depth_u16.type() != CV_16UC1) {
      return absl::NotFoundError("cannot read " + f.rgb_path + " / " + f.depth_path);
    }
    kf.depth_m = DepthToMetres(depth_u16, kTumDepthScale);
    LOCI_ASSIGN_OR_RETURN(kf.features, ExtractFeatures(kf.bgr, kf.depth_m, camera, options));
    const StampedPose* gt =
        NearestByTime(std::span<const StampedPose>(seq.groundtruth), f.rgb_t_ns, kMaxGtDtNs);
    if (gt) {
      kf.has_gt = true;
      kf.T_world_cam = gt->T_world_cam;
    }
    kf.gt_speed_deg_s = SpeedDegS(seq.groundtruth, f.rgb_t_ns);
    if (!keep_images) {
      kf.bgr.release();
      kf.depth_m.release();
    }
    out.push_back(std::move(kf));
  }
  return out;
}

SE3d GroundTruthT_a_b(const TumKeyframe& a, const TumKeyframe& b) {
  return a.T_world_cam.inverse() * b.T_world_cam;
}

std::string FullFr1RpyDir() { return loci::testing::FullTumSequence("tum_fr1_rpy"); }

}  // namespace loci::place::testing
