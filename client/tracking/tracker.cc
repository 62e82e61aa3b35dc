#include "client/tracking/tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <unordered_set>

#include "client/tracking/local_ba.h"
#include "client/tracking/pose_refiner.h"
#include "common/image_codec.h"

namespace loci {
namespace {

SE3d PoseFromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  SE3d T = SE3d::Identity();
  T.linear() = Re;
  T.translation() = Vec3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return T;
}

void PoseToRvecTvec(const SE3d& T, cv::Mat* rvec, cv::Mat* tvec) {
  cv::Mat R;
  Eigen::Matrix3d Re = T.linear();
  cv::eigen2cv(Re, R);
  cv::Rodrigues(R, *rvec);
  *tvec = (cv::Mat_<double>(3, 1) << T.translation().x(), T.translation().y(), T.translation().z());
}

// Rate of a rotation over dt_ns, rad/s (axis times angle over time).
Vec3d TurnRate(const SE3d& T_step, int64_t dt_ns) {
  const Eigen::AngleAxisd turn(T_step.linear());
  return turn.axis() * (turn.angle() / (static_cast<double>(dt_ns) * 1e-9));
}

// PnP-RANSAC over 3-D world points and pixels; returns the inlier count (0 on failure).
int PnpRansac(const std::vector<cv::Point3f>& obj, const std::vector<cv::Point2f>& img,
              const PinholeCamera& cam, int iterations, double reproj_px, SE3d* T_cw) {
  if (obj.size() < 6) return 0;
  cv::Mat K;
  cv::eigen2cv(cam.K(), K);
  cv::Mat rvec, tvec;
  PoseToRvecTvec(*T_cw, &rvec, &tvec);
  std::vector<int> inliers;
  const bool ok =
      cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, true, iterations,
                         static_cast<float>(reproj_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
  if (!ok) return 0;
  const SE3d T = PoseFromRvecTvec(rvec, tvec);
  if (!IsFinite(T)) return 0;
  *T_cw = T;
  return static_cast<int>(inliers.size());
}

// Observations whose reprojection error under T_cw is below max_px.
int CountInliers(const PinholeCamera& cam, const std::vector<PoseObservation>& obs,
                 const SE3d& T_cw, double max_px) {
  int n = 0;
  for (const PoseObservation& o : obs) {
    const auto uv = cam.Project(T_cw * o.p_world);
    n += uv && (*uv - o.uv_px).squaredNorm() <= max_px * max_px;
  }
  return n;
}

}  // namespace

const char* TrackStateName(TrackState s) {
  switch (s) {
    case TrackState::kInitialised:
      return "initialised";
    case TrackState::kTracking:
      return "tracking";
    case TrackState::kRelocalised:
      return "relocalised";
    case TrackState::kLost:
      return "lost";
    case TrackState::kNewSegment:
      return "new_segment";
  }
  return "?";
}

Tracker::Tracker(const TrackerOptions& options)
    : opt_(options), extractor_(options), dynamic_(options), map_(options.local_map_keyframes) {}

StatusOr<std::unique_ptr<Tracker>> Tracker::Create(const TrackerOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  return std::unique_ptr<Tracker>(new Tracker(options));
}

namespace {

Status CheckTrackInput(const PinholeCamera& cam, const cv::Mat& image, const cv::Mat& depth_u16) {
  if (image.empty() || (image.type() != CV_8UC3 && image.type() != CV_8UC1)) {
    return absl::InvalidArgumentError("Track: image must be CV_8UC3 or CV_8UC1");
  }
  if (image.cols != cam.width_px || image.rows != cam.height_px) {
    return absl::InvalidArgumentError(absl::StrCat("Track: image is ", image.cols, "x", image.rows,
                                                   ", camera expects ", cam.width_px, "x",
                                                   cam.height_px));
  }
  if (depth_u16.type() != CV_16UC1 || depth_u16.size() != image.size()) {
    return absl::InvalidArgumentError("Track: depth must be CV_16UC1 of the image size");
  }
  return absl::OkStatus();
}

}  // namespace

StatusOr<FrameResult> Tracker::Track(const cv::Mat& image, const cv::Mat& depth_u16, int64_t t_ns,
                                     const std::vector<Detection2D>* detections) {
  const auto t0 = std::chrono::steady_clock::now();
  LOCI_RETURN_IF_ERROR(CheckTrackInput(opt_.camera, image, depth_u16));
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = image;
  }
  const cv::Mat depth_m = DepthToMetres(depth_u16, opt_.depth_scale);
  OrbFrame frame = extractor_.Extract(gray, depth_m, t_ns);
  if (detections && opt_.dynamic.enabled) dynamic_.AssignWeights(*detections, &frame);
  ++frame_index_;

  FrameResult r;
  r.t_ns = t_ns;
  r.num_features = static_cast<int>(frame.size());
  r.segment = segment_;
  auto finish = [&]() {
    r.num_map_points = static_cast<int>(map_.num_points());
    r.track_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };

  if (map_.empty()) {
    // First frame of a segment: the map starts here, at the last known pose.
    StartSegment(std::move(frame), t_ns, &r);
    r.state = segment_ == 0 ? TrackState::kInitialised : TrackState::kNewSegment;
    return finish();
  }

  const SE3d T_cw_pred = have_velocity_ ? velocity_ * T_cw_last_ : T_cw_last_;
  SE3d T_cw = T_cw_pred;
  std::vector<PointMatch> matches;
  r.state = TrackState::kTracking;
  const int inliers = TrackOrRelocalise(frame, T_cw_pred, &T_cw, &matches, &r.state);
  if (inliers < opt_.min_inliers) {
    ++lost_count_;
    if (lost_count_ >= opt_.lost_frames_before_reset) {
      // Unrecoverable: a new segment starts from the last known pose (continuity for viewers;
      // the server is told through FrameResult::segment that it is unrelated).
      ++segment_;
      map_.Clear();
      StartSegment(std::move(frame), t_ns, &r);
      r.state = TrackState::kNewSegment;
      r.segment = segment_;
      return finish();
    }
    r.state = TrackState::kLost;
    r.tracked = false;
    r.T_odom_cam = T_cw_pred.inverse();
    return finish();
  }
  lost_count_ = 0;
  r.tracked = true;
  r.num_matches = static_cast<int>(matches.size());
  r.num_inliers = inliers;
  r.num_dynamic = MarkMatchedPoints(frame, T_cw, matches);
  UpdateVelocity(T_cw, t_ns);
  T_cw_last_ = T_cw;
  last_t_ns_ = t_ns;
  r.T_odom_cam = T_cw.inverse();
  if (NeedKeyframe(frame, T_cw, matches, inliers)) {
    CreateKeyframe(std::move(frame), T_cw, matches);
    last_kf_frame_ = frame_index_;
    r.keyframe = true;
    AdjustNewKeyframe(&r);
  }
  return finish();
}

void Tracker::StartSegment(OrbFrame frame, int64_t t_ns, FrameResult* r) {
  CreateKeyframe(std::move(frame), T_cw_last_, {});
  have_velocity_ = false;
  last_t_ns_ = t_ns;
  lost_count_ = 0;
  last_kf_frame_ = frame_index_;
  r->tracked = true;
  r->keyframe = true;
  r->T_odom_cam = T_cw_last_.inverse();
}

int Tracker::TrackOrRelocalise(const OrbFrame& frame, const SE3d& T_cw_pred, SE3d* T_cw,
                               std::vector<PointMatch>* matches, TrackState* state) {
  int inliers = TrackLocalMap(frame, T_cw_pred, T_cw, matches);
  if (inliers >= opt_.min_inliers) return inliers;
  SE3d T_reloc = T_cw_last_;
  matches->clear();
  inliers = 0;
  if (Relocalise(frame, &T_reloc)) {
    inliers = TrackLocalMap(frame, T_reloc, T_cw, matches);
    *state = TrackState::kRelocalised;
    have_velocity_ = false;
  }
  return inliers;
}

int Tracker::MarkMatchedPoints(const OrbFrame& frame, const SE3d& T_cw,
                               const std::vector<PointMatch>& matches) {
  int dynamic = 0;
  for (const PointMatch& m : matches) {
    dynamic += m.dynamic;
    if (m.inlier && !m.dynamic) {
      ++m.point->found;
      m.point->last_uv_px =
          Vec3d(frame.keypoints[m.kp].pt.x, frame.keypoints[m.kp].pt.y, 0).head<2>();
      m.point->last_T_world_cam = T_cw.inverse();
      m.point->last_seen_frame = frame_index_;
    }
    if (m.dynamic) ++m.point->dynamic_votes;
  }
  return dynamic;
}

void Tracker::AdjustNewKeyframe(FrameResult* r) {
  if (opt_.local_ba_keyframes <= 0) return;
  LocalBaOptions ba;
  ba.num_optimised_keyframes = opt_.local_ba_keyframes;
  ba.max_iterations = opt_.local_ba_iterations;
  ba.bf_px = opt_.camera.fx * opt_.virtual_baseline_m;
  std::vector<float> inv_sigma2(opt_.orb.num_levels);
  for (int l = 0; l < opt_.orb.num_levels; ++l) {
    inv_sigma2[l] = 1.f / (extractor_.LevelScale(l) * extractor_.LevelScale(l));
  }
  if (LocalBundleAdjust(opt_.camera, ba, inv_sigma2, &map_)) {
    // The new keyframe is this frame: continue from its adjusted pose.
    T_cw_last_ = map_.LastKeyframe()->T_world_cam.inverse();
    r->T_odom_cam = map_.LastKeyframe()->T_world_cam;
  }
}

void Tracker::UpdateVelocity(const SE3d& T_cw, int64_t t_ns) {
  seed_w_cam_rad_s_.reset();
  prev_w_cam_rad_s_.reset();
  if (have_velocity_ && velocity_dt_ns_ > 0) {
    prev_w_cam_rad_s_ = TurnRate(velocity_, velocity_dt_ns_);
  }
  velocity_ = T_cw * T_cw_last_.inverse();
  velocity_dt_ns_ = t_ns - last_t_ns_;
  have_velocity_ = true;
}

std::optional<Vec3d> Tracker::RecentTurnRate() const {
  if (!have_velocity_ || velocity_dt_ns_ <= 0) return seed_w_cam_rad_s_;
  const Vec3d w = TurnRate(velocity_, velocity_dt_ns_);
  return prev_w_cam_rad_s_ ? Vec3d(0.5 * (w + *prev_w_cam_rad_s_)) : w;
}

std::optional<SE3d> Tracker::PredictedMotion(int64_t from_t_ns, int64_t to_t_ns) const {
  if (!have_velocity_ || velocity_dt_ns_ <= 0) return std::nullopt;
  if (std::abs(to_t_ns - from_t_ns) > velocity_dt_ns_) return std::nullopt;  // not extrapolated
  const double s = static_cast<double>(to_t_ns - from_t_ns) / static_cast<double>(velocity_dt_ns_);
  const Eigen::AngleAxisd rotation(velocity_.linear());
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(rotation.angle() * s, rotation.axis()).toRotationMatrix();
  T.translation() = velocity_.translation() * s;
  return T;
}

int Tracker::TrackLocalMap(const OrbFrame& frame, const SE3d& T_cw_init, SE3d* T_cw,
                           std::vector<PointMatch>* matches) {
  const PinholeCamera& cam = opt_.camera;
  const double bf = cam.fx * opt_.virtual_baseline_m;
  std::vector<MapPoint*> points = map_.Points();
  std::vector<char> kp_taken(frame.size(), 0);
  ProjectionSearchParams sp;
  sp.radius_px = opt_.search_radius_px;
  sp.max_hamming = opt_.max_hamming;
  sp.ratio = opt_.match_ratio;
  sp.num_levels = opt_.orb.num_levels;
  sp.scale_factor = opt_.orb.scale_factor;
  sp.count_visible = true;
  matches->clear();
  SearchByProjection(frame, T_cw_init, cam, points, sp, frame_index_, &kp_taken, matches);
  if (static_cast<int>(matches->size()) < opt_.min_inliers) return 0;

  auto observation = [&](const PointMatch& m) {
    const cv::KeyPoint& kp = frame.keypoints[m.kp];
    PoseObservation o;
    o.p_world = m.point->p_world;
    o.uv_px = Eigen::Vector2d(kp.pt.x, kp.pt.y);
    const float z = frame.depth_m[m.kp];
    o.ur_px = z > 0 ? kp.pt.x - bf / z : -1.0;
    const double s = extractor_.LevelScale(kp.octave);
    o.inv_sigma2 = 1.0 / (s * s);
    return o;
  };

  // First estimate from features that are not prior-dynamic (paper 004: F and T from Q_s).
  std::vector<int> idx;
  std::vector<PoseObservation> obs;
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> img;
  for (size_t i = 0; i < matches->size(); ++i) {
    const PointMatch& m = (*matches)[i];
    if (dynamic_.IsPriorDynamic(frame.class_weight[m.kp])) continue;
    idx.push_back(static_cast<int>(i));
    obs.push_back(observation(m));
    obj.emplace_back(m.point->p_world.x(), m.point->p_world.y(), m.point->p_world.z());
    img.push_back(frame.keypoints[m.kp].pt);
  }
  SE3d T_start = T_cw_init;
  SE3d T_pnp = T_cw_init;
  const int pnp_inliers = PnpRansac(obj, img, cam, opt_.pnp_iterations, opt_.pnp_reproj_px, &T_pnp);
  // Start from whichever of the prediction and the RANSAC pose explains more matches.
  if (pnp_inliers >= opt_.min_inliers && CountInliers(cam, obs, T_pnp, opt_.pnp_reproj_px) >
                                             CountInliers(cam, obs, T_start, opt_.pnp_reproj_px)) {
    T_start = T_pnp;
  }
  PoseRefineResult a = RefinePose(cam, bf, obs, T_start);
  if (a.num_inliers < opt_.min_inliers) return a.num_inliers;
  *T_cw = a.T_cam_world;

  // Tighter second search around the refined pose for points the first pass missed.
  sp.radius_px = opt_.refine_radius_px;
  sp.count_visible = false;
  SearchByProjection(frame, *T_cw, cam, points, sp, frame_index_, &kp_taken, matches);

  // Dynamic test of every match with the static pose; dynamic ones leave the estimate.
  obs.clear();
  idx.clear();
  for (size_t i = 0; i < matches->size(); ++i) {
    PointMatch& m = (*matches)[i];
    const cv::KeyPoint& kp = frame.keypoints[m.kp];
    m.dynamic = false;
    if (opt_.dynamic.enabled) {
      const bool has_prev = m.point->last_seen_frame >= 0;
      const double D = dynamic_.DynamicValue(Eigen::Vector2d(kp.pt.x, kp.pt.y), frame.depth_m[m.kp],
                                             m.point->p_world, *T_cw, has_prev, m.point->last_uv_px,
                                             m.point->last_T_world_cam);
      m.dynamic = D > dynamic_.Threshold(frame.class_weight[m.kp]);
    }
    if (m.dynamic) continue;
    idx.push_back(static_cast<int>(i));
    obs.push_back(observation(m));
  }
  PoseRefineResult fin = RefinePose(cam, bf, obs, *T_cw);
  for (PointMatch& m : *matches) m.inlier = false;
  for (size_t j = 0; j < idx.size(); ++j) (*matches)[idx[j]].inlier = fin.inlier[j];
  if (fin.num_inliers >= opt_.min_inliers) *T_cw = fin.T_cam_world;
  return fin.num_inliers;
}

bool Tracker::Relocalise(const OrbFrame& frame, SE3d* T_cw) {
  const auto& kfs = map_.keyframes();
  // Newest keyframes first: after a short loss the camera is most likely near them.
  for (auto it = kfs.rbegin(); it != kfs.rend(); ++it) {
    const KeyframeRecord& kf = **it;
    const auto pairs = MatchBruteForce(frame, kf.frame, opt_.max_hamming, 0.8f);
    if (static_cast<int>(pairs.size()) < 2 * opt_.min_inliers) continue;
    std::vector<cv::Point3f> obj;
    std::vector<cv::Point2f> img;
    for (const auto& [i, j] : pairs) {
      const Vec3d p_w = kf.T_world_cam * kf.frame.p_cam[j];
      obj.emplace_back(p_w.x(), p_w.y(), p_w.z());
      img.push_back(frame.keypoints[i].pt);
    }
    SE3d T = kf.T_world_cam.inverse();
    if (PnpRansac(obj, img, opt_.camera, 300, opt_.pnp_reproj_px, &T) >= 2 * opt_.min_inliers) {
      *T_cw = T;
      return true;
    }
  }
  return false;
}

bool Tracker::NeedKeyframe(const OrbFrame& frame, const SE3d& T_cw,
                           const std::vector<PointMatch>& matches, int num_inliers) const {
  const KeyframeRecord* last = map_.LastKeyframe();
  if (!last) return true;
  const KeyframeRuleOptions& k = opt_.keyframes;
  if (frame_index_ - last_kf_frame_ >= k.max_frames_between) return true;
  if (num_inliers < k.min_tracked_points) return true;
  // Paper 004 eq. (6): effective motion relative to the last keyframe.
  const SE3d T_kf_cur = last->T_world_cam.inverse() * T_cw.inverse();
  const bool moved = RotationAngleRad(T_kf_cur) > k.min_rotation_rad ||
                     T_kf_cur.translation().norm() > k.min_translation_m;
  if (!moved) return false;
  // Eq. (7): static co-visibility index mu = |N1 and N2| / N1, N1 = static features of this
  // frame (with depth, not dynamic), N2 = static points of the last keyframe.
  std::unordered_set<int64_t> kf_points(last->point_ids.begin(), last->point_ids.end());
  int common = 0, dynamic = 0;
  std::vector<char> matched(frame.size(), 0);
  for (const PointMatch& m : matches) {
    matched[m.kp] = 1;
    if (m.dynamic) ++dynamic;
    if (m.inlier && !m.dynamic && kf_points.count(m.point->id)) ++common;
  }
  int static_features = -dynamic;
  for (size_t i = 0; i < frame.size(); ++i) {
    static_features += frame.depth_m[i] > 0 && !dynamic_.IsPriorDynamic(frame.class_weight[i]);
  }
  const double mu = static_features <= 0 ? 0.0 : static_cast<double>(common) / static_features;
  int new_points = 0;
  for (size_t i = 0; i < frame.size(); ++i) new_points += !matched[i] && frame.depth_m[i] > 0;
  return mu < k.max_covisibility && new_points > k.min_new_points;
}

void Tracker::CreateKeyframe(OrbFrame frame, const SE3d& T_cw,
                             const std::vector<PointMatch>& matches) {
  auto kf = std::make_unique<KeyframeRecord>();
  kf->id = next_kf_id_++;
  kf->frame_index = frame_index_;
  kf->T_world_cam = T_cw.inverse();
  std::vector<char> used(frame.size(), 0);
  for (const PointMatch& m : matches) {
    used[m.kp] = 1;
    if (!m.inlier || m.dynamic) continue;
    // The newest view describes the point best for the frames that follow.
    m.point->descriptor = frame.descriptors[m.kp];
    m.point->octave = frame.keypoints[m.kp].octave;
    if (frame.depth_m[m.kp] > 0) {
      m.point->ref_depth_m = frame.depth_m[m.kp];
      // Depth noise grows with z^2 (Kinect): average the keyframes' measurements of the point
      // with inverse-variance weights, which removes most of a single view's depth noise.
      const double z = frame.depth_m[m.kp];
      const double w = 1.0 / (z * z * z * z);
      if (m.point->weight <= 0) m.point->weight = w;
      const Vec3d p_new = kf->T_world_cam * frame.p_cam[m.kp];
      m.point->p_world = (m.point->p_world * m.point->weight + p_new * w) / (m.point->weight + w);
      m.point->weight += w;
    }
    kf->point_ids.push_back(m.point->id);
    kf->point_kp.push_back(m.kp);
  }
  for (size_t i = 0; i < frame.size(); ++i) {
    if (used[i] || frame.depth_m[i] <= 0) continue;
    // Untested features in boxes of dynamic classes never enter the map.
    if (dynamic_.IsPriorDynamic(frame.class_weight[i])) continue;
    MapPoint* p = map_.AddPoint(kf->T_world_cam * frame.p_cam[i], frame.descriptors[i],
                                frame.keypoints[i].octave, frame.depth_m[i]);
    p->last_uv_px = Eigen::Vector2d(frame.keypoints[i].pt.x, frame.keypoints[i].pt.y);
    p->last_T_world_cam = kf->T_world_cam;
    p->last_seen_frame = frame_index_;
    p->weight = 1.0 / std::pow(frame.depth_m[i], 4.0);
    kf->point_ids.push_back(p->id);
    kf->point_kp.push_back(static_cast<int>(i));
  }
  kf->frame = std::move(frame);
  map_.AddKeyframe(std::move(kf));
  map_.CullPoints();
}

}  // namespace loci
