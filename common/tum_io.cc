#include "common/tum_io.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "absl/strings/numbers.h"
#include "common/time.h"

namespace loci {
namespace fs = std::filesystem;

StatusOr<std::vector<StampedLine>> ReadStampedFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  std::vector<StampedLine> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string stamp;
    if (!(ss >> stamp)) continue;  // blank line
    auto t = ParseSecondsToNs(stamp);
    if (!t.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ":", line_no, ": ", t.status().message()));
    }
    StampedLine sl;
    sl.t_ns = *t;
    for (std::string f; ss >> f;) sl.fields.push_back(f);
    out.push_back(std::move(sl));
  }
  return out;
}

std::vector<std::pair<size_t, size_t>> AssociateStamps(const std::vector<int64_t>& a,
                                                       const std::vector<int64_t>& b,
                                                       int64_t max_dt_ns) {
  struct Cand {
    int64_t dt;
    size_t i, j;
  };
  std::vector<Cand> cands;
  // b sorted copy with indices for a windowed search (O(n log n) instead of associate.py's n^2).
  std::vector<size_t> order(b.size());
  for (size_t j = 0; j < b.size(); ++j) order[j] = j;
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return b[x] < b[y]; });
  std::vector<int64_t> sorted_b(b.size());
  for (size_t k = 0; k < order.size(); ++k) sorted_b[k] = b[order[k]];
  for (size_t i = 0; i < a.size(); ++i) {
    auto lo = std::lower_bound(sorted_b.begin(), sorted_b.end(), a[i] - max_dt_ns);
    for (auto it = lo; it != sorted_b.end() && *it <= a[i] + max_dt_ns; ++it) {
      const int64_t dt = std::llabs(*it - a[i]);
      if (dt < max_dt_ns) cands.push_back({dt, i, order[it - sorted_b.begin()]});
    }
  }
  std::stable_sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) {
    return x.dt != y.dt ? x.dt < y.dt : (x.i != y.i ? x.i < y.i : x.j < y.j);
  });
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<std::pair<size_t, size_t>> out;
  for (const Cand& c : cands) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = true;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

StatusOr<Trajectory> TrajectoryFromLines(const std::vector<StampedLine>& lines,
                                         const std::string& path) {
  Trajectory traj;
  traj.reserve(lines.size());
  for (const StampedLine& l : lines) {
    if (l.fields.size() < 7) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": pose line needs 't tx ty tz qx qy qz qw'"));
    }
    double v[7];
    for (int k = 0; k < 7; ++k) {
      if (!absl::SimpleAtod(l.fields[k], &v[k])) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": bad number '", l.fields[k], "'"));
      }
    }
    LOCI_RETURN_IF_ERROR(ValidatePose(Vec3d(v[0], v[1], v[2]), v[6], v[3], v[4], v[5], 1e-2));
    traj.push_back({l.t_ns, SE3FromTum(v[0], v[1], v[2], v[3], v[4], v[5], v[6])});
  }
  return traj;
}

std::string Resolve(const std::string& dir, const std::string& rel) {
  return (fs::path(dir) / rel).string();
}

}  // namespace

StatusOr<Trajectory> ReadTumTrajectory(const std::string& path) {
  LOCI_ASSIGN_OR_RETURN(auto lines, ReadStampedFile(path));
  return TrajectoryFromLines(lines, path);
}

Status WriteTumTrajectory(const std::string& path, const Trajectory& traj) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError(absl::StrCat("cannot write ", path));
  out << "# timestamp tx ty tz qx qy qz qw (T_world_cam)\n";
  char buf[256];
  for (const StampedPose& p : traj) {
    const Vec3d t = p.T_world_cam.translation();
    const Quatd q = QuatOf(p.T_world_cam);
    std::snprintf(buf, sizeof(buf), "%s %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n",
                  FormatNsAsSeconds(p.t_ns).c_str(), t.x(), t.y(), t.z(), q.x(), q.y(), q.z(),
                  q.w());
    out << buf;
  }
  if (!out) return absl::DataLossError(absl::StrCat("short write to ", path));
  return absl::OkStatus();
}

StatusOr<TumSequence> LoadTumSequence(const std::string& dir, int64_t max_dt_ns) {
  if (!fs::is_directory(dir)) {
    return absl::NotFoundError(absl::StrCat("TUM folder not found: ", dir));
  }
  TumSequence seq;
  seq.dir = dir;
  LOCI_ASSIGN_OR_RETURN(auto rgb, ReadStampedFile(Resolve(dir, "rgb.txt")));
  LOCI_ASSIGN_OR_RETURN(auto depth, ReadStampedFile(Resolve(dir, "depth.txt")));
  std::vector<int64_t> ta, tb;
  for (const auto& l : rgb) {
    if (l.fields.empty()) return absl::InvalidArgumentError(dir + "/rgb.txt: missing file name");
    ta.push_back(l.t_ns);
  }
  for (const auto& l : depth) {
    if (l.fields.empty()) return absl::InvalidArgumentError(dir + "/depth.txt: missing file name");
    tb.push_back(l.t_ns);
  }
  for (auto [i, j] : AssociateStamps(ta, tb, max_dt_ns)) {
    seq.frames.push_back({rgb[i].t_ns, depth[j].t_ns, Resolve(dir, rgb[i].fields[0]),
                          Resolve(dir, depth[j].fields[0])});
  }
  if (seq.frames.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(dir, ": no rgb/depth pair within ",
                                                   max_dt_ns / 1e6, " ms"));
  }
  const std::string gt = Resolve(dir, "groundtruth.txt");
  if (fs::exists(gt)) {
    LOCI_ASSIGN_OR_RETURN(seq.groundtruth, ReadTumTrajectory(gt));
  }
  const std::string acc = Resolve(dir, "accelerometer.txt");
  if (fs::exists(acc)) {
    LOCI_ASSIGN_OR_RETURN(auto lines, ReadStampedFile(acc));
    for (const auto& l : lines) {
      double v[3];
      if (l.fields.size() < 3 || !absl::SimpleAtod(l.fields[0], &v[0]) ||
          !absl::SimpleAtod(l.fields[1], &v[1]) || !absl::SimpleAtod(l.fields[2], &v[2])) {
        return absl::InvalidArgumentError(acc + ": line needs 't ax ay az'");
      }
      seq.accel.push_back({l.t_ns, Eigen::Vector3d(v[0], v[1], v[2])});
    }
  }
  return seq;
}

std::optional<SE3d> InterpolatePose(const Trajectory& sorted, int64_t t_ns, int64_t max_gap_ns) {
  const auto hi = std::lower_bound(sorted.begin(), sorted.end(), t_ns,
                                   [](const StampedPose& p, int64_t t) { return p.t_ns < t; });
  if (hi == sorted.end()) return std::nullopt;
  if (hi->t_ns == t_ns) return hi->T_world_cam;
  if (hi == sorted.begin()) return std::nullopt;
  const StampedPose& lo = *(hi - 1);
  if (hi->t_ns - lo.t_ns > max_gap_ns) return std::nullopt;
  const double f = static_cast<double>(t_ns - lo.t_ns) / static_cast<double>(hi->t_ns - lo.t_ns);
  const Eigen::Quaterniond q0(lo.T_world_cam.rotation()), q1(hi->T_world_cam.rotation());
  SE3d T = SE3d::Identity();
  T.linear() = q0.slerp(f, q1).toRotationMatrix();
  T.translation() = (1 - f) * lo.T_world_cam.translation() + f * hi->T_world_cam.translation();
  return T;
}

StatusOr<Eigen::Vector3d> GravityInCamAt(const std::vector<AccelSample>& accel, int64_t t_ns,
                                         int64_t max_dt_ns) {
  auto lo = std::lower_bound(accel.begin(), accel.end(), t_ns - max_dt_ns,
                             [](const AccelSample& s, int64_t t) { return s.t_ns < t; });
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (auto it = lo; it != accel.end() && it->t_ns <= t_ns + max_dt_ns; ++it, ++n) {
    sum += it->accel_mps2;
  }
  if (n == 0 || sum.norm() < 1e-6) {
    return absl::NotFoundError("no accelerometer sample near this time");
  }
  const Eigen::Vector3d a = sum / n;
  return Eigen::Vector3d(a.x(), a.y(), -a.z()).normalized();
}

}  // namespace loci
