#include "detection/multi_object_tracker.h"

#include <algorithm>

#include "common/config.h"
#include "detection/decode.h"
#include "detection/hungarian.h"

namespace loci::detection {
namespace {
constexpr double kForbidden = 1e9;
}  // namespace

// The keys FromYaml reads, per section (CheckKnownKeys warns about any other).
constexpr const char* kTrackerKeys[] = {"n_init",
                                        "max_age",
                                        "min_iou",
                                        "mahalanobis_gate",
                                        "max_appearance_distance",
                                        "motion_weight",
                                        "max_cascade_cost",
                                        "max_iou_distance",
                                        "appearance_momentum",
                                        "std_weight_position",
                                        "std_weight_velocity",
                                        "min_position_std_px",
                                        "min_velocity_std_px",
                                        "hue_bins",
                                        "saturation_bins",
                                        "min_saturation"};

StatusOr<TrackerOptions> TrackerOptions::FromYaml(const YAML::Node& node) {
  TrackerOptions o;
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, "tracker", kTrackerKeys));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "n_init", &o.n_init));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_age", &o.max_age));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_iou", &o.min_iou));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "mahalanobis_gate", &o.mahalanobis_gate));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_appearance_distance", &o.max_appearance_distance));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "motion_weight", &o.motion_weight));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_cascade_cost", &o.max_cascade_cost));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_iou_distance", &o.max_iou_distance));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "appearance_momentum", &o.appearance_momentum));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "std_weight_position", &o.std_weight_position));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "std_weight_velocity", &o.std_weight_velocity));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_position_std_px", &o.min_position_std_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_velocity_std_px", &o.min_velocity_std_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "hue_bins", &o.appearance.hue_bins));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "saturation_bins", &o.appearance.saturation_bins));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_saturation", &o.appearance.min_saturation));
  LOCI_RETURN_IF_ERROR(o.Validate());
  return o;
}

Status TrackerOptions::Validate() const {
  if (n_init < 1 || max_age < 1) {
    return absl::InvalidArgumentError("tracker: n_init and max_age must be >= 1");
  }
  if (!(min_iou >= 0.f && min_iou <= 1.f) || !(mahalanobis_gate > 0.0) ||
      !(motion_weight >= 0.0 && motion_weight <= 1.0) || !(max_cascade_cost > 0.0) ||
      !(max_iou_distance > 0.0 && max_iou_distance <= 1.0) ||
      !(appearance_momentum >= 0.0 && appearance_momentum < 1.0) ||
      !(max_appearance_distance > 0.0) || !(std_weight_position > 0.0) ||
      !(std_weight_velocity > 0.0) || !(min_position_std_px >= 0.0) ||
      !(min_velocity_std_px >= 0.0)) {
    return absl::InvalidArgumentError("tracker: a gate, weight or noise parameter is out of range");
  }
  if (appearance.hue_bins < 1 || appearance.saturation_bins < 1 || appearance.max_side_px < 1) {
    return absl::InvalidArgumentError("tracker: histogram bins must be >= 1");
  }
  return absl::OkStatus();
}

MultiObjectTracker::MultiObjectTracker(TrackerOptions options) : options_(std::move(options)) {}

void MultiObjectTracker::Reset() {
  tracks_.clear();
  next_id_ = 1;
  next_internal_id_ = 1;
}

template <typename CostFn>
void MultiObjectTracker::Match(const std::vector<int>& track_idx, std::vector<int>* det_idx,
                               CostFn cost, std::vector<std::pair<int, int>>* matches) {
  if (track_idx.empty() || det_idx->empty()) return;
  std::vector<std::vector<double>> c(track_idx.size(), std::vector<double>(det_idx->size()));
  for (size_t r = 0; r < track_idx.size(); ++r) {
    for (size_t k = 0; k < det_idx->size(); ++k) c[r][k] = cost(track_idx[r], (*det_idx)[k]);
  }
  const std::vector<int> assign = SolveAssignment(c, kForbidden);
  std::vector<char> used(det_idx->size(), false);
  for (size_t r = 0; r < track_idx.size(); ++r) {
    if (assign[r] < 0) continue;
    matches->emplace_back(track_idx[r], (*det_idx)[assign[r]]);
    used[assign[r]] = true;
  }
  std::vector<int> rest;
  for (size_t k = 0; k < det_idx->size(); ++k) {
    if (!used[k]) rest.push_back((*det_idx)[k]);
  }
  *det_idx = std::move(rest);
}

void MultiObjectTracker::Update(const cv::Mat& bgr, std::vector<Detection2D>* detections) {
  std::vector<Detection2D>& dets = *detections;
  for (Track& t : tracks_) {
    t.kf.Predict();
    ++t.age;
    ++t.time_since_update;
  }
  Frame f{&dets, {}, std::vector<cv::Mat>(dets.size()), !bgr.empty() && bgr.type() == CV_8UC3};
  if (f.use_appearance) {
    for (size_t i = 0; i < dets.size(); ++i) {
      f.features[i] = HsvHistogram(bgr, dets[i].box_px, dets[i].mask, options_.appearance);
    }
  }
  f.predicted.resize(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) f.predicted[i] = tracks_[i].kf.Box();

  std::vector<int> unmatched_dets(dets.size());
  for (size_t i = 0; i < dets.size(); ++i) unmatched_dets[i] = static_cast<int>(i);
  std::vector<std::pair<int, int>> matches;
  std::vector<char> matched_track(tracks_.size(), false);
  Associate(f, &unmatched_dets, &matches, &matched_track);
  UpdateMatched(f, matches, &dets);
  DropStaleTracks(matched_track);
  StartTracks(f, unmatched_dets, &dets);
}

double MultiObjectTracker::CascadeCost(const Frame& f, int ti, int di) const {
  const Track& t = tracks_[ti];
  const Detection2D& d = (*f.dets)[di];
  if (t.class_id != d.class_id || t.class_name != d.class_name) return kForbidden;
  const double iou = BoxIou(f.predicted[ti], d.box_px);
  const double maha = t.kf.MahalanobisSq(d.box_px);
  if (iou < options_.min_iou && maha > options_.mahalanobis_gate) return kForbidden;
  const double motion = std::min(1.0 - iou, maha / options_.mahalanobis_gate);
  double cost = motion;
  if (f.use_appearance && !t.feature.empty() && !f.features[di].empty()) {
    const double app = HistogramDistance(t.feature, f.features[di]);
    if (app > options_.max_appearance_distance) return kForbidden;
    cost = options_.motion_weight * motion + (1.0 - options_.motion_weight) * app;
  }
  return cost <= options_.max_cascade_cost ? cost : kForbidden;
}

double MultiObjectTracker::IouCost(const Frame& f, int ti, int di) const {
  const Track& t = tracks_[ti];
  const Detection2D& d = (*f.dets)[di];
  if (t.class_id != d.class_id || t.class_name != d.class_name) return kForbidden;
  const double dist = 1.0 - BoxIou(f.predicted[ti], d.box_px);
  if (dist <= options_.max_iou_distance) return dist;
  // A young track has no velocity yet: fall back to the cascade cost (Mahalanobis-gated,
  // with appearance), offset so IoU matches are preferred.
  const double c = CascadeCost(f, ti, di);
  return c < kForbidden ? 1.0 + c : kForbidden;
}

void MultiObjectTracker::Associate(const Frame& f, std::vector<int>* unmatched_dets,
                                   std::vector<std::pair<int, int>>* matches,
                                   std::vector<char>* matched_track) {
  // Stage 1: matching cascade over confirmed tracks, most recently seen first.
  const auto cascade_cost = [&](int ti, int di) { return CascadeCost(f, ti, di); };
  for (int level = 1; level <= options_.max_age + 1 && !unmatched_dets->empty(); ++level) {
    std::vector<int> level_tracks;
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (tracks_[i].state == Track::State::kConfirmed && tracks_[i].time_since_update == level) {
        level_tracks.push_back(static_cast<int>(i));
      }
    }
    Match(level_tracks, unmatched_dets, cascade_cost, matches);
  }
  for (const auto& [ti, di] : *matches) (*matched_track)[ti] = true;

  // Stage 2: IoU matching for tentative tracks and confirmed tracks missed only this update.
  std::vector<int> iou_tracks;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if ((*matched_track)[i]) continue;
    if (tracks_[i].state == Track::State::kTentative || tracks_[i].time_since_update == 1) {
      iou_tracks.push_back(static_cast<int>(i));
    }
  }
  const size_t first_stage = matches->size();
  Match(
      iou_tracks, unmatched_dets, [&](int ti, int di) { return IouCost(f, ti, di); }, matches);
  for (size_t k = first_stage; k < matches->size(); ++k)
    (*matched_track)[(*matches)[k].first] = true;
}

void MultiObjectTracker::UpdateMatched(const Frame& f,
                                       const std::vector<std::pair<int, int>>& matches,
                                       std::vector<Detection2D>* dets) {
  for (Detection2D& d : *dets) d.track_id = 0;
  for (const auto& [ti, di] : matches) {
    Track& t = tracks_[ti];
    t.kf.Update((*dets)[di].box_px);
    ++t.hits;
    t.time_since_update = 0;
    const cv::Mat& feature = f.features[di];
    if (!feature.empty()) {
      if (t.feature.empty()) {
        t.feature = feature.clone();
      } else {
        t.feature = options_.appearance_momentum * t.feature +
                    (1.0 - options_.appearance_momentum) * feature;
      }
    }
    if (t.state == Track::State::kTentative && t.hits >= options_.n_init) {
      t.state = Track::State::kConfirmed;
      t.id = next_id_++;
    }
    if (t.state == Track::State::kConfirmed) (*dets)[di].track_id = t.id;
  }
}

void MultiObjectTracker::DropStaleTracks(const std::vector<char>& matched_track) {
  // Tentative tracks that missed and confirmed tracks older than max_age go.
  std::vector<Track> kept;
  kept.reserve(tracks_.size());
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    if (!matched_track[i] &&
        (t.state == Track::State::kTentative || t.time_since_update > options_.max_age)) {
      continue;
    }
    kept.push_back(std::move(t));
  }
  tracks_ = std::move(kept);
}

void MultiObjectTracker::StartTracks(const Frame& f, const std::vector<int>& unmatched_dets,
                                     std::vector<Detection2D>* dets) {
  for (int di : unmatched_dets) {
    Detection2D& d = (*dets)[di];
    Track t{.kf = KalmanBoxFilter(d.box_px, options_.std_weight_position,
                                  options_.std_weight_velocity, options_.min_position_std_px,
                                  options_.min_velocity_std_px)};
    t.class_id = d.class_id;
    t.class_name = d.class_name;
    t.hits = 1;
    t.age = 1;
    t.feature = f.features[di];
    t.internal_id = next_internal_id_++;
    if (options_.n_init <= 1) {
      t.state = Track::State::kConfirmed;
      t.id = next_id_++;
      d.track_id = t.id;
    }
    tracks_.push_back(std::move(t));
  }
}

}  // namespace loci::detection
