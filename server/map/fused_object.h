// One physical object of the map: its voxelised fused cloud in the map frame, label
// distribution and bookkeeping (paper 000 3.3: centroid = mean of the object's points, eq. 16).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "common/map_object.h"
#include "common/status.h"
#include "server/map/label_distribution.h"
#include "server/map/voxel_key.h"

namespace loci::store::v1 {
class FusedObjectState;
}  // namespace loci::store::v1

namespace loci::server {

inline uint32_t PackRgb(uint8_t r, uint8_t g, uint8_t b) {
  return (static_cast<uint32_t>(r) << 16) | (static_cast<uint32_t>(g) << 8) | b;
}

// One coloured point of the map frame.
struct ColoredPoint {
  Eigen::Vector3f p_m = Eigen::Vector3f::Zero();
  uint32_t rgb = 0;  // 0xRRGGBB
};

// Evidence for the object's shape: the fused cloud keeps every observation's voxels, but its
// geometry (centroid, boxes) and exported cloud use only voxels in support cells (edge cell_m)
// that at least max(2, ceil(min_fraction * observations)) observations put points in, once the
// object has 3 observations or more. One bad mask (the wall behind a cup) or a misaligned view
// then no longer stretches the object. min_fraction 0 = every voxel counts.
// Once the object's most likely class has min_label_views observations with points, only those
// count (cells and observations both): views of another class fused in (a monitor and the
// keyboard before it, called "laptop") add evidence for the label and existence, not shape
// (0 = every observation counts).
struct SupportOptions {
  double cell_m = 0.05;
  double min_fraction = 0.25;
  // The box-centre centroid ignores parts (connected cell_m cells) of the supported points that
  // hold less than this fraction of them (point_components.h), so a stray cluster does not move
  // it while a contiguous part, a table's legs, always counts (0 = the full box).
  double centroid_min_part = 0.0;
  // Flat-topped furniture (FusionOptions::flat_top_classes): geometry from the points up to
  // flat_top_margin_m above its top surface (the densest level layer).
  std::vector<std::string> flat_top_classes;
  double flat_top_margin_m = 0.03;
  int min_label_views = 3;
  // The object's bottom height (MapObject::bottom_z_m) is this quantile of those points'
  // heights (0 = the box's bottom).
  double bottom_quantile = 0.05;
};

// A FusedObject's voxel and support cell (at namespace scope: a nested struct with member
// initializers is not default-constructible until its class is complete, and the voxel tables
// need that inside the class).
struct FusedObjectVoxel {
  Eigen::Vector3d sum_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rgb_sum = Eigen::Vector3d::Zero();
  uint32_t count = 0;
};
struct FusedObjectCell {
  uint32_t observations = 0;  // observations with points in the cell
  uint32_t last = 0;          // index of the last observation counted
  uint32_t moved = 0;         // stamp of the last MovePoints pass that counted it (not saved)
  // The same per class (index into FusedObject's point labels), small: (label, observations).
  std::vector<std::pair<uint16_t, uint32_t>> by_label;
  uint32_t Of(int label) const;
  void Add(int label, int64_t delta);
};

// class_name is one of the flat-topped furniture classes (SupportOptions::flat_top_classes).
bool IsFlatTopClass(const std::vector<std::string>& flat_top_classes,
                    const std::string& class_name);

class FusedObject {
 public:
  // centroid_from_box: see FusionOptions::centroid_from_box.
  FusedObject(int64_t id, double voxel_m, bool centroid_from_box, const LabelDistribution& labels,
              SupportOptions support = {})
      : id_(id),
        voxel_m_(voxel_m),
        centroid_from_box_(centroid_from_box),
        support_(support),
        labels_(labels) {}

  // Adds one observation's points (map frame) detected as class_name; each voxel keeps the mean
  // of its points.
  void AddPoints(const std::vector<ColoredPoint>& points_m, const std::string& class_name);
  // Moves one earlier observation: takes out its points as they were added (old_m, exactly the
  // same values) and adds them at their new place (new_m); labels and bookkeeping stay. The
  // geometry (centroid, boxes) is stale until RecomputeGeometry (once after many moves).
  void MovePoints(const std::vector<ColoredPoint>& old_m, const std::vector<ColoredPoint>& new_m,
                  const std::string& class_name);
  void RecomputeGeometry();
  // Absorbs another object (duplicate merge): points, labels, bookkeeping.
  void Absorb(const FusedObject& other);
  // Records one keyframe's observation of this object.
  void Observe(const std::string& class_name, double score, int64_t session_row, int64_t track_id,
               const std::string& robot, int64_t keyframe_id, int64_t t_ns);
  // Records a keyframe that should have seen the object but did not (visibility.h). Misses are
  // kept per keyframe, as hits are: two pieces of one object missed in the same keyframe and then
  // merged hold one miss for it, and none where the other piece saw it.
  void Miss(int64_t keyframe_id, int64_t t_ns);
  // Existence as a log-odds belief: the prior's log-odds, plus log(p_detect / p_false) per time
  // window of window_ns in which a keyframe saw the object, plus log((1 - p_detect) /
  // (1 - p_false)) per window whose keyframes should have seen it and did not. Keyframes a
  // fraction of a second apart share their viewpoint, blur and light, so a detector's hits and
  // misses come in bursts: a window is one piece of evidence. Things get moved: between two
  // windows dt apart, the belief that the object is still there is multiplied by
  // exp(-dt / stays_s), stays_s the mean time a thing of its class stays put (<= 0: forever), so
  // a place seen empty a day later outweighs hours of sightings the day before.
  struct ExistenceModel {
    double prior = 0.03, p_detect = 0.5, p_false = 0.1;
    int64_t window_ns = 500'000'000;
    double stays_s = 0;
    double max_log_odds = std::numeric_limits<double>::infinity();  // clamp after each window
  };
  struct Evidence {
    int hits = 0, misses = 0;  // windows
  };
  Evidence EvidenceOver(int64_t window_ns) const;
  // The evidence windows in time order: (start, whether a keyframe in it saw the object).
  std::vector<std::pair<int64_t, bool>> EvidenceWindows(int64_t window_ns) const;
  double ExistenceLogOdds(const ExistenceModel& m) const;
  void SetConfirmed(bool confirmed) { confirmed_ = confirmed; }
  // Hits / (hits + misses), for display.
  double existence() const {
    return observation_count() / std::max(1.0, double(observation_count()) + misses());
  }
  uint32_t misses() const { return static_cast<uint32_t>(missed_t_ns_.size()); }
  // The keyframes that missed it after its last sighting, oldest first; returns the newest one's
  // time (0: none).
  int64_t MissesSinceLastHit(std::vector<int64_t>* keyframe_ids) const;
  // Up to 48 of the object's supported points (map frame), and its largest half extent, m.
  const std::vector<Eigen::Vector3d>& sample_m() const { return sample_m_; }
  double half_size_m() const { return obb_half_m_.maxCoeff(); }
  // Oriented box (map frame): centre, half extents along its axes, and the axes (columns): an
  // upright box (upright_box.h), turned about up to the footprint's smallest rectangle.
  const Eigen::Vector3d& obb_center_m() const { return obb_center_m_; }
  const Eigen::Vector3d& obb_half_m() const { return obb_half_m_; }
  const Eigen::Matrix3d& R_map_box() const { return R_map_box_; }
  // Keeps the camera distance of the nearest view (range_m <= 0: unknown, ignored).
  void ObserveRange(double range_m);
  double nearest_range_m() const { return nearest_range_m_; }  // 0: unknown

  // Voxel keys of the fused points at `voxel_m` (overlap measure).
  VoxelSet KeysAt(double voxel_m) const;
  // The same for the voxels that shape the object (SupportOptions: supported cells, the views
  // of its most likely class): what the object is, not every view fused into it.
  VoxelSet ShapeKeysAt(double voxel_m) const;
  const std::set<std::pair<int64_t, int64_t>>& tracks() const { return tracks_; }
  bool HasTrack(int64_t session_row, int64_t track_id) const {
    return track_id != 0 && tracks_.count({session_row, track_id}) > 0;
  }

  int64_t id() const { return id_; }
  // The id it is known by: an object seen again at a new place takes the id it had at the old
  // one (ObjectMap).
  void set_id(int64_t id) { id_ = id; }
  int64_t first_seen_ns() const { return first_seen_ns_; }  // map time of its first sighting
  int64_t last_seen_ns() const { return last_seen_ns_; }
  const Eigen::Vector3d& centroid_m() const { return centroid_m_; }
  const Eigen::Vector3d& aabb_min_m() const { return aabb_min_m_; }  // map axes
  const Eigen::Vector3d& aabb_max_m() const { return aabb_max_m_; }
  const LabelDistribution& labels() const { return labels_; }
  uint32_t observation_count() const { return static_cast<uint32_t>(keyframes_.size()); }
  bool confirmed() const { return confirmed_; }
  const std::vector<int64_t>& keyframes() const { return keyframes_; }
  size_t voxel_count() const { return voxels_.size(); }

  // Fused cloud (one point per supported voxel, see SupportOptions) in the map frame.
  std::vector<ColoredPoint> Cloud() const;
  MapObject Snapshot() const;

  // Checkpoint state (map_checkpoint.cc): the evidence; the geometry is recomputed from it.
  void SaveState(loci::store::v1::FusedObjectState* out) const;
  Status LoadState(const loci::store::v1::FusedObjectState& in);

 private:
  using Voxel = FusedObjectVoxel;
  using Cell = FusedObjectCell;
  // Which observations shape the object now: those of one point label (-1: all), and how many
  // of them a cell needs.
  struct SupportRule {
    int label = -1;
    uint32_t min_observations = 1;
  };
  SupportRule CurrentSupportRule() const;
  // Whether a voxel (mean point p) lies in a cell with enough observations.
  bool Supported(const Eigen::Vector3d& p, const SupportRule& rule) const;
  // Its most likely class is flat-topped furniture (SupportOptions::flat_top_classes).
  bool IsFlatTop() const;
  // Index of a class among the point labels (added when new).
  int PointLabel(const std::string& class_name);
  Status LoadCells(const loci::store::v1::FusedObjectState& in);

  int64_t id_;
  double voxel_m_;
  bool centroid_from_box_;
  SupportOptions support_;
  LabelDistribution labels_;
  VoxelMap<Voxel> voxels_;
  VoxelMap<Cell> cells_;
  uint32_t point_observations_ = 0;  // AddPoints calls (absorbed objects' included)
  std::vector<std::string> point_labels_;            // classes of the observations with points
  std::vector<uint32_t> label_point_observations_;   // AddPoints calls per point label
  uint32_t move_stamp_ = 0;          // MovePoints passes (two per call)
  size_t supported_voxels_ = 0;      // voxels the geometry used at the last recompute
  Eigen::Vector3d centroid_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_min_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_max_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d obb_center_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d obb_half_m_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_map_box_ = Eigen::Matrix3d::Identity();
  double top_surface_z_m_ = 0;
  double bottom_z_m_ = 0;
  int64_t first_seen_ns_ = 0;
  int64_t last_seen_ns_ = 0;
  std::set<std::string> robots_;
  std::string last_robot_;
  std::vector<int64_t> keyframes_;                // distinct, in observation order
  std::map<int64_t, int64_t> hit_t_ns_;           // keyframe -> its time
  std::set<std::pair<int64_t, int64_t>> tracks_;  // (session_row, track_id)
  bool confirmed_ = false;
  std::map<int64_t, int64_t> missed_t_ns_;  // keyframe -> time; none of them in keyframes_
  double nearest_range_m_ = 0;
  std::vector<Eigen::Vector3d> sample_m_;
};

}  // namespace loci::server
