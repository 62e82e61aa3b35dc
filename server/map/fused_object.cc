#include "server/map/fused_object.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "server/map/point_components.h"
#include "server/map/upright_box.h"

namespace loci::server {

uint32_t FusedObjectCell::Of(int label) const {
  for (const auto& [l, n] : by_label) {
    if (l == label) return n;
  }
  return 0;
}

void FusedObjectCell::Add(int label, int64_t delta) {
  for (auto it = by_label.begin(); it != by_label.end(); ++it) {
    if (it->first != label) continue;
    it->second = static_cast<uint32_t>(std::max<int64_t>(0, it->second + delta));
    if (it->second == 0) by_label.erase(it);
    return;
  }
  if (delta > 0) by_label.emplace_back(static_cast<uint16_t>(label), static_cast<uint32_t>(delta));
}

int FusedObject::PointLabel(const std::string& class_name) {
  auto it = std::find(point_labels_.begin(), point_labels_.end(), class_name);
  if (it != point_labels_.end()) return static_cast<int>(it - point_labels_.begin());
  point_labels_.push_back(class_name);
  label_point_observations_.push_back(0);
  return static_cast<int>(point_labels_.size()) - 1;
}

void FusedObject::AddPoints(const std::vector<ColoredPoint>& points_m,
                            const std::string& class_name) {
  ++point_observations_;
  const int label = PointLabel(class_name);
  ++label_point_observations_[label];
  for (const ColoredPoint& cp : points_m) {
    const Eigen::Vector3d p = cp.p_m.cast<double>();
    Cell& cell = cells_[KeyOf(p, support_.cell_m)];
    if (cell.last != point_observations_) {
      cell.last = point_observations_;
      ++cell.observations;
      cell.Add(label, 1);
    }
    Voxel& v = voxels_[KeyOf(p, voxel_m_)];
    v.sum_m += p;
    v.rgb_sum += Eigen::Vector3d((cp.rgb >> 16) & 0xff, (cp.rgb >> 8) & 0xff, cp.rgb & 0xff);
    ++v.count;
  }
  RecomputeGeometry();
}

void FusedObject::MovePoints(const std::vector<ColoredPoint>& old_m,
                             const std::vector<ColoredPoint>& new_m,
                             const std::string& class_name) {
  // Each cell counts an observation once: a stamp per pass marks the cells already counted
  // (as AddPoints does with `last`, which a move leaves alone).
  const uint32_t out_stamp = ++move_stamp_, in_stamp = ++move_stamp_;
  const int label = PointLabel(class_name);
  for (const ColoredPoint& cp : old_m) {
    const Eigen::Vector3d p = cp.p_m.cast<double>();
    auto cell = cells_.find(KeyOf(p, support_.cell_m));
    if (cell != cells_.end() && cell->second.moved != out_stamp) {
      cell->second.moved = out_stamp;
      cell->second.Add(label, -1);
      if (--cell->second.observations == 0) cells_.erase(cell);
    }
    auto it = voxels_.find(KeyOf(p, voxel_m_));
    if (it == voxels_.end()) continue;  // not this object's (it never held the observation)
    Voxel& v = it->second;
    v.sum_m -= p;
    v.rgb_sum -= Eigen::Vector3d((cp.rgb >> 16) & 0xff, (cp.rgb >> 8) & 0xff, cp.rgb & 0xff);
    if (--v.count == 0) voxels_.erase(it);
  }
  for (const ColoredPoint& cp : new_m) {
    const Eigen::Vector3d p = cp.p_m.cast<double>();
    Cell& cell = cells_[KeyOf(p, support_.cell_m)];
    if (cell.moved != in_stamp) {
      cell.moved = in_stamp;
      ++cell.observations;
      cell.Add(label, 1);
    }
    Voxel& v = voxels_[KeyOf(p, voxel_m_)];
    v.sum_m += p;
    v.rgb_sum += Eigen::Vector3d((cp.rgb >> 16) & 0xff, (cp.rgb >> 8) & 0xff, cp.rgb & 0xff);
    ++v.count;
  }
}

void FusedObject::Absorb(const FusedObject& other) {
  for (const auto& [key, ov] : other.voxels_) {
    Voxel& v = voxels_[key];
    v.sum_m += ov.sum_m;
    v.rgb_sum += ov.rgb_sum;
    v.count += ov.count;
  }
  std::vector<int> label_of(other.point_labels_.size());  // other's point label -> ours
  for (size_t i = 0; i < other.point_labels_.size(); ++i) {
    label_of[i] = PointLabel(other.point_labels_[i]);
    label_point_observations_[label_of[i]] += other.label_point_observations_[i];
  }
  for (const auto& [key, oc] : other.cells_) {
    Cell& cell = cells_[key];
    cell.observations += oc.observations;
    for (const auto& [l, n] : oc.by_label) cell.Add(label_of[l], n);
  }
  point_observations_ += other.point_observations_;
  labels_.Merge(other.labels_);
  first_seen_ns_ = std::min(first_seen_ns_, other.first_seen_ns_);
  if (other.last_seen_ns_ > last_seen_ns_) {
    last_seen_ns_ = other.last_seen_ns_;
    last_robot_ = other.last_robot_;
  }
  robots_.insert(other.robots_.begin(), other.robots_.end());
  for (int64_t kf : other.keyframes_) {
    if (std::find(keyframes_.begin(), keyframes_.end(), kf) == keyframes_.end()) {
      keyframes_.push_back(kf);
    }
  }
  std::sort(keyframes_.begin(), keyframes_.end());
  tracks_.insert(other.tracks_.begin(), other.tracks_.end());
  hit_t_ns_.insert(other.hit_t_ns_.begin(), other.hit_t_ns_.end());
  missed_t_ns_.insert(other.missed_t_ns_.begin(), other.missed_t_ns_.end());
  for (const auto& [kf, t_ns] : hit_t_ns_) missed_t_ns_.erase(kf);
  ObserveRange(other.nearest_range_m_);
  RecomputeGeometry();
}

void FusedObject::Observe(const std::string& class_name, double score, int64_t session_row,
                          int64_t track_id, const std::string& robot, int64_t keyframe_id,
                          int64_t t_ns) {
  labels_.Update(class_name, score);
  if (keyframes_.empty()) first_seen_ns_ = t_ns;
  first_seen_ns_ = std::min(first_seen_ns_, t_ns);
  if (t_ns >= last_seen_ns_) {
    last_seen_ns_ = t_ns;
    last_robot_ = robot;
  }
  robots_.insert(robot);
  if (keyframes_.empty() || keyframes_.back() != keyframe_id) keyframes_.push_back(keyframe_id);
  hit_t_ns_.emplace(keyframe_id, t_ns);
  missed_t_ns_.erase(keyframe_id);
  if (track_id != 0) tracks_.insert({session_row, track_id});
}

void FusedObject::ObserveRange(double range_m) {
  if (range_m > 0 && (nearest_range_m_ <= 0 || range_m < nearest_range_m_)) {
    nearest_range_m_ = range_m;
  }
}

std::vector<std::pair<int64_t, bool>> FusedObject::EvidenceWindows(int64_t window_ns) const {
  std::vector<std::pair<int64_t, bool>> events;  // (t_ns, hit)
  events.reserve(hit_t_ns_.size() + missed_t_ns_.size());
  for (const auto& [kf, t_ns] : hit_t_ns_) events.emplace_back(t_ns, true);
  for (const auto& [kf, t_ns] : missed_t_ns_) events.emplace_back(t_ns, false);
  std::sort(events.begin(), events.end());
  std::vector<std::pair<int64_t, bool>> windows;
  for (size_t i = 0; i < events.size();) {
    const int64_t start_ns = events[i].first;
    const int64_t end_ns = start_ns + std::max<int64_t>(window_ns, 1);
    bool hit = false;
    for (; i < events.size() && events[i].first < end_ns; ++i) hit |= events[i].second;
    windows.emplace_back(start_ns, hit);
  }
  return windows;
}

FusedObject::Evidence FusedObject::EvidenceOver(int64_t window_ns) const {
  Evidence e;
  for (const auto& [t_ns, hit] : EvidenceWindows(window_ns)) ++(hit ? e.hits : e.misses);
  return e;
}

namespace {

// log(p / (1 - p)) of the belief `log_odds` after the thing may have been moved for dt_s.
double Forget(double log_odds, double dt_s, double stays_s) {
  if (stays_s <= 0 || dt_s <= 0) return log_odds;
  const double p = 1.0 / (1.0 + std::exp(-log_odds)) * std::exp(-dt_s / stays_s);
  return std::log(std::max(p, 1e-300) / (1 - p));
}

}  // namespace

double FusedObject::ExistenceLogOdds(const ExistenceModel& m) const {
  const double hit = std::log(m.p_detect / m.p_false);
  const double miss = std::log((1 - m.p_detect) / (1 - m.p_false));
  double log_odds = std::log(m.prior / (1 - m.prior));
  int64_t last_ns = 0;
  bool first = true;
  for (const auto& [t_ns, seen] : EvidenceWindows(m.window_ns)) {
    if (!first) log_odds = Forget(log_odds, 1e-9 * static_cast<double>(t_ns - last_ns), m.stays_s);
    first = false;
    last_ns = t_ns;
    log_odds = std::min(log_odds + (seen ? hit : miss), m.max_log_odds);
  }
  return log_odds;
}

int64_t FusedObject::MissesSinceLastHit(std::vector<int64_t>* keyframe_ids) const {
  int64_t last_hit_ns = std::numeric_limits<int64_t>::min();
  for (const auto& [kf, t_ns] : hit_t_ns_) last_hit_ns = std::max(last_hit_ns, t_ns);
  std::vector<std::pair<int64_t, int64_t>> after;  // (t_ns, keyframe)
  for (const auto& [kf, t_ns] : missed_t_ns_) {
    if (t_ns > last_hit_ns) after.emplace_back(t_ns, kf);
  }
  std::sort(after.begin(), after.end());
  keyframe_ids->clear();
  for (const auto& [t_ns, kf] : after) keyframe_ids->push_back(kf);
  return after.empty() ? 0 : after.back().first;
}

void FusedObject::Miss(int64_t keyframe_id, int64_t t_ns) {
  if (hit_t_ns_.count(keyframe_id) == 0) missed_t_ns_.emplace(keyframe_id, t_ns);
}

VoxelSet FusedObject::KeysAt(double voxel_m) const {
  VoxelSet keys;
  keys.reserve(voxels_.size());
  for (const auto& [key, v] : voxels_) keys.insert(KeyOf(v.sum_m / v.count, voxel_m));
  return keys;
}

VoxelSet FusedObject::ShapeKeysAt(double voxel_m) const {
  if (supported_voxels_ == 0) return KeysAt(voxel_m);
  const SupportRule rule = CurrentSupportRule();
  VoxelSet keys;
  keys.reserve(supported_voxels_);
  for (const auto& [key, v] : voxels_) {
    const Eigen::Vector3d p = v.sum_m / v.count;
    if (Supported(p, rule)) keys.insert(KeyOf(p, voxel_m));
  }
  return keys;
}

FusedObject::SupportRule FusedObject::CurrentSupportRule() const {
  SupportRule rule;
  uint32_t observations = point_observations_;
  if (support_.min_label_views > 0) {
    auto it = std::find(point_labels_.begin(), point_labels_.end(), labels_.Argmax());
    const int label = it == point_labels_.end() ? -1 : static_cast<int>(it - point_labels_.begin());
    if (label >= 0 && label_point_observations_[label] >=
                          static_cast<uint32_t>(support_.min_label_views)) {
      rule.label = label;
      observations = label_point_observations_[label];
    }
  }
  if (observations >= 3 && support_.min_fraction > 0) {
    rule.min_observations = std::max<uint32_t>(
        2, static_cast<uint32_t>(std::ceil(support_.min_fraction * observations)));
  }
  return rule;
}

bool FusedObject::Supported(const Eigen::Vector3d& p, const SupportRule& rule) const {
  if (rule.label < 0 && rule.min_observations <= 1) return true;
  const auto it = cells_.find(KeyOf(p, support_.cell_m));
  if (it == cells_.end()) return false;
  const uint32_t n = rule.label >= 0 ? it->second.Of(rule.label) : it->second.observations;
  return n >= rule.min_observations;
}

std::vector<ColoredPoint> FusedObject::Cloud() const {
  std::vector<ColoredPoint> out;
  out.reserve(voxels_.size());
  const bool any_supported = supported_voxels_ > 0;
  const SupportRule rule = CurrentSupportRule();
  for (const auto& [key, v] : voxels_) {
    if (any_supported && !Supported(v.sum_m / v.count, rule)) continue;
    const Eigen::Vector3d rgb = v.rgb_sum / v.count;
    out.push_back({(v.sum_m / v.count).cast<float>(), (static_cast<uint32_t>(rgb.x()) << 16) |
                                                          (static_cast<uint32_t>(rgb.y()) << 8) |
                                                          static_cast<uint32_t>(rgb.z())});
  }
  return out;
}

namespace {

// Centre of the 2 cm z layer holding the most points (the map frame is z up).
double DensestLayerZ(const std::vector<Eigen::Vector3d>& pts) {
  constexpr double kLayerM = 0.02;
  std::unordered_map<int64_t, int> layers;
  int64_t best = 0;
  int best_n = 0;
  for (const Eigen::Vector3d& p : pts) {
    const int64_t k = static_cast<int64_t>(std::floor(p.z() / kLayerM));
    const int n = ++layers[k];
    if (n > best_n || (n == best_n && k > best)) {
      best = k;
      best_n = n;
    }
  }
  return (best + 0.5) * kLayerM;
}

// The q-quantile of the points' heights (map z; q 0 = the lowest). `pts` must not be empty.
double HeightQuantile(const std::vector<Eigen::Vector3d>& pts, double q) {
  std::vector<double> z_m;
  z_m.reserve(pts.size());
  for (const Eigen::Vector3d& p : pts) z_m.push_back(p.z());
  const size_t k = static_cast<size_t>(std::clamp(q, 0.0, 1.0) * (z_m.size() - 1));
  std::nth_element(z_m.begin(), z_m.begin() + k, z_m.end());
  return z_m[k];
}

}  // namespace

void FusedObject::RecomputeGeometry() {
  if (voxels_.empty()) return;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  aabb_min_m_.setConstant(std::numeric_limits<double>::max());
  aabb_max_m_.setConstant(std::numeric_limits<double>::lowest());
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(voxels_.size());
  const SupportRule rule = CurrentSupportRule();
  for (const auto& [key, v] : voxels_) {
    if (Supported(v.sum_m / v.count, rule)) pts.push_back(v.sum_m / v.count);
  }
  supported_voxels_ = pts.size();
  if (pts.empty()) {  // no cell has the support yet: every voxel counts
    for (const auto& [key, v] : voxels_) pts.push_back(v.sum_m / v.count);
  }
  top_surface_z_m_ = DensestLayerZ(pts);
  if (IsFlatTop()) {  // what stands on the top is other objects
    std::vector<Eigen::Vector3d> below;
    for (const Eigen::Vector3d& p : pts) {
      if (p.z() <= top_surface_z_m_ + support_.flat_top_margin_m) below.push_back(p);
    }
    pts.swap(below);
  }
  for (const Eigen::Vector3d& p : pts) {
    sum += p;
    aabb_min_m_ = aabb_min_m_.cwiseMin(p);
    aabb_max_m_ = aabb_max_m_.cwiseMax(p);
  }
  bottom_z_m_ = HeightQuantile(pts, support_.bottom_quantile);
  const Eigen::Vector3d mean = sum / static_cast<double>(pts.size());
  const UprightBox box = FitUprightBox(pts);
  R_map_box_ = box.R_map_box;
  obb_center_m_ = box.center_m;
  obb_half_m_ = box.half_extent_m;
  centroid_m_ = centroid_from_box_
                    ? BoxCentreAlong(MainParts(pts, support_.cell_m, support_.centroid_min_part),
                                     R_map_box_)
                    : mean;
  sample_m_.clear();
  const size_t stride = std::max<size_t>(1, pts.size() / 48);
  for (size_t i = 0; i < pts.size(); i += stride) sample_m_.push_back(pts[i]);
}

bool IsFlatTopClass(const std::vector<std::string>& flat_top_classes,
                    const std::string& class_name) {
  return std::find(flat_top_classes.begin(), flat_top_classes.end(), class_name) !=
         flat_top_classes.end();
}

bool FusedObject::IsFlatTop() const {
  return IsFlatTopClass(support_.flat_top_classes, labels_.Argmax());
}

MapObject FusedObject::Snapshot() const {
  MapObject o;
  o.id = id_;
  o.class_name = labels_.Argmax();
  o.confidence = labels_.Probability(o.class_name);
  o.labels = labels_.Observed();
  o.centroid_m = centroid_m_;
  o.aabb_min_m = aabb_min_m_;
  o.aabb_max_m = aabb_max_m_;
  o.obb_center_m = obb_center_m_;
  o.obb_half_extent_m = obb_half_m_;
  o.R_map_box = R_map_box_;
  o.first_seen_ns = first_seen_ns_;
  o.last_seen_ns = last_seen_ns_;
  o.robots.assign(robots_.begin(), robots_.end());
  o.last_robot = last_robot_;
  o.observation_count = observation_count();
  o.point_count = static_cast<uint32_t>(supported_voxels_ > 0 ? supported_voxels_ : voxels_.size());
  o.confirmed = confirmed_;
  o.missed_views = misses();
  o.existence = existence();
  o.top_surface_z_m = top_surface_z_m_;
  o.bottom_z_m = bottom_z_m_;
  return o;
}

}  // namespace loci::server
