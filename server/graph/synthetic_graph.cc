#include "server/graph/synthetic_graph.h"

#include <cmath>
#include <limits>

#include "server/graph/graph_math.h"
#include "server/graph/pose_graph.h"

namespace loci::server {
namespace {

constexpr int64_t kStepNs = 100'000'000;  // 0.1 s between keyframes

// Camera (x right, y down, z forward) in a body frame (x forward, y left, z up).
Mat3d RotationBodyCam() {
  Mat3d R;
  R.col(0) = Vec3d(0, -1, 0);
  R.col(1) = Vec3d(0, 0, -1);
  R.col(2) = Vec3d(1, 0, 0);
  return R;
}

Mat3d Rz(double yaw) { return Eigen::AngleAxisd(yaw, Vec3d::UnitZ()).toRotationMatrix(); }

Vec6d Gaussian6(double sigma_t, double sigma_r, std::mt19937* rng) {
  std::normal_distribution<double> t(0, sigma_t), r(0, sigma_r);
  Vec6d e;
  e << t(*rng), t(*rng), t(*rng), r(*rng), r(*rng), r(*rng);
  return e;
}

SE3d NoisyOdometry(const SE3d& T_map_prev, const SE3d& T_map_kf, const OdometryNoiseOptions& n,
                   std::mt19937* rng) {
  SE3d Z = T_map_prev.inverse() * T_map_kf;
  Z.translation() *= 1 + n.scale_bias;
  Vec6d e = Gaussian6(n.trans_sigma_m, n.rot_sigma_rad, rng);
  e.tail<3>() += n.yaw_bias_rad * (T_map_kf.rotation().transpose() * Vec3d::UnitZ());
  return Z * PoseFromError6(e);
}

// The estimate with the true roll and pitch and its own yaw.
SE3d Levelled(const SE3d& T_est, const SE3d& T_true) {
  SE3d T = T_est;
  T.linear() = Rz(YawOf(T_est.rotation() * T_true.rotation().transpose())) * T_true.rotation();
  return T;
}

}  // namespace

std::vector<SE3d> SquarePath(const SquarePathOptions& o) {
  const double h = o.side_m / 2;
  const Vec3d corners[4] = {{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}};
  const Mat3d R_body_cam_pitched =
      Eigen::AngleAxisd(o.camera_pitch_rad, Vec3d::UnitY()).toRotationMatrix() *
      RotationBodyCam();
  std::vector<SE3d> path;
  for (int k = 0; k < o.keyframes; ++k) {
    const double laps = static_cast<double>(k) / o.keyframes_per_lap + o.lap_phase;
    const double sides = 4 * (laps - std::floor(laps));
    const int side = std::min(3, static_cast<int>(sides));
    const double along = sides - side;
    const Vec3d from = corners[side], to = corners[(side + 1) % 4];
    SE3d T = SE3d::Identity();
    T.translation() = from + along * (to - from) +
                      Vec3d(0, 0, o.z_amplitude_m * std::sin(2 * M_PI * along));
    T.linear() = Rz(side * M_PI / 2) * R_body_cam_pitched;
    path.push_back(o.T_map_square * T);
  }
  return path;
}

SyntheticRobot MakeSyntheticRobot(const std::string& robot, int64_t first_id,
                                  const std::vector<SE3d>& truth,
                                  const OdometryNoiseOptions& noise,
                                  const SE3d& T_map_first_guess, bool gravity_aligned,
                                  std::mt19937* rng) {
  SyntheticRobot r;
  r.robot = robot;
  r.T_map_kf_true = truth;
  SE3d T_est = T_map_first_guess;
  for (size_t k = 0; k < truth.size(); ++k) {
    const SE3d Z = k == 0 ? SE3d::Identity() : NoisyOdometry(truth[k - 1], truth[k], noise, rng);
    if (k > 0) T_est = T_est * Z;
    r.T_prev_kf.push_back(Z);
    KeyframeNode n;
    n.keyframe_id = first_id + static_cast<int64_t>(k);
    n.robot = robot;
    n.t_ns = n.keyframe_id * kStepNs;
    n.T_map_kf = gravity_aligned ? Levelled(T_est, truth[k]) : T_est;
    n.gravity_aligned = gravity_aligned;
    r.nodes.push_back(n);
  }
  return r;
}

std::vector<GraphEdge> ProximityEdges(const SyntheticRobot& a, const SyntheticRobot& b,
                                      EdgeKind kind, const ProximityEdgeOptions& o,
                                      std::mt19937* rng) {
  const bool same = a.robot == b.robot;
  std::vector<GraphEdge> edges;
  int since_last = o.every;
  for (size_t j = 0; j < b.T_map_kf_true.size(); ++j) {
    if (++since_last < o.every) continue;
    double best = std::numeric_limits<double>::infinity();
    size_t best_i = 0;
    const size_t end = same ? (j >= static_cast<size_t>(o.min_gap) ? j - o.min_gap + 1 : 0)
                            : a.T_map_kf_true.size();
    const Vec3d t_map_b = b.T_map_kf_true[j].translation();
    for (size_t i = 0; i < end; ++i) {
      const double d = (a.T_map_kf_true[i].translation() - t_map_b).norm();
      if (d >= best || d > o.max_distance_m) continue;
      if (RotationAngleRad(a.T_map_kf_true[i].inverse() * b.T_map_kf_true[j]) <= o.max_angle_rad) {
        best = d;
        best_i = i;
      }
    }
    if (!std::isfinite(best)) continue;
    since_last = 0;
    const SE3d T_a_b = a.T_map_kf_true[best_i].inverse() * b.T_map_kf_true[j] *
                       PoseFromError6(Gaussian6(o.trans_sigma_m, o.rot_sigma_rad, rng));
    edges.push_back({kind, a.nodes[best_i].keyframe_id, b.nodes[j].keyframe_id, T_a_b,
                     IsotropicInformation(o.trans_sigma_m, o.rot_sigma_rad)});
  }
  return edges;
}

std::vector<Vec3d> ObjectsAroundSquare(const SquarePathOptions& path, int count,
                                       std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-0.5 - path.side_m / 2, 0.5 + path.side_m / 2);
  std::uniform_real_distribution<double> z(-0.8, 0.6);
  std::vector<Vec3d> objects;
  for (int i = 0; i < count; ++i) objects.push_back(path.T_map_square * Vec3d(u(*rng), u(*rng), z(*rng)));
  return objects;
}

std::vector<CentroidObservation> ObserveCentroids(const SyntheticRobot& robot,
                                                  const std::vector<Vec3d>& objects_map,
                                                  double max_range_m, double sigma_m,
                                                  std::mt19937* rng) {
  std::normal_distribution<double> noise(0, sigma_m);
  std::vector<CentroidObservation> seen;
  for (size_t k = 0; k < robot.T_map_kf_true.size(); ++k) {
    const SE3d T_kf_map = robot.T_map_kf_true[k].inverse();
    for (size_t o = 0; o < objects_map.size(); ++o) {
      const Vec3d c = T_kf_map * objects_map[o];
      const bool in_view = c.z() > 0.2 && std::abs(c.x()) < 0.7 * c.z() &&
                           std::abs(c.y()) < 0.52 * c.z() && c.norm() <= max_range_m;
      if (!in_view) continue;
      seen.push_back({robot.nodes[k].keyframe_id, static_cast<int64_t>(o),
                      c + Vec3d(noise(*rng), noise(*rng), noise(*rng))});
    }
  }
  return seen;
}

Status AddRobot(const SyntheticRobot& robot, PoseGraph* graph) {
  for (size_t k = 0; k < robot.nodes.size(); ++k) {
    LOCI_RETURN_IF_ERROR(graph->AddKeyframe(robot.nodes[k]));
    if (k == 0) continue;
    LOCI_RETURN_IF_ERROR(graph->AddOdometryEdge(robot.nodes[k - 1].keyframe_id,
                                                robot.nodes[k].keyframe_id, robot.T_prev_kf[k],
                                                TrackingQuality{1.0, -1}));
  }
  return absl::OkStatus();
}

Status AddConstraints(const std::vector<GraphEdge>& edges, PoseGraph* graph) {
  for (const GraphEdge& e : edges) {
    const Status s = e.kind == EdgeKind::kMerge
                         ? graph->AddMergeEdge(e.from_id, e.to_id, e.T_a_b, e.information)
                         : graph->AddLoopEdge(e.from_id, e.to_id, e.T_a_b, e.information);
    LOCI_RETURN_IF_ERROR(s);
  }
  return absl::OkStatus();
}

Trajectory TrueTrajectory(const SyntheticRobot& robot) {
  Trajectory t;
  for (size_t k = 0; k < robot.nodes.size(); ++k) {
    t.push_back({robot.nodes[k].t_ns, robot.T_map_kf_true[k]});
  }
  return t;
}

Trajectory EstimatedTrajectory(const SyntheticRobot& robot, const PoseGraph& graph) {
  std::unordered_map<int64_t, SE3d> estimate;
  for (const KeyframeNode& n : graph.nodes()) estimate[n.keyframe_id] = n.T_map_kf;
  Trajectory t;
  for (const KeyframeNode& n : robot.nodes) {
    const auto it = estimate.find(n.keyframe_id);
    if (it != estimate.end()) t.push_back({n.t_ns, it->second});
  }
  return t;
}

}  // namespace loci::server
