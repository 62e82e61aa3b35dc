// `loci eval loops --db FILE --groundtruth groundtruth.txt [--offset-ms N] [--json]`: the
// verified loop matches a server stored (place_matches) against the ground truth, beside the
// odometry the robot sent between the same two keyframes. A pose graph gains from its loops only
// where they are closer to the truth than the odometry they join; this says whether they are,
// overall, by the match's 3D fit RMS and by the time between its keyframes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "common/relative_pose_eval.h"
#include "common/trajectory_eval.h"
#include "server/storage/sqlite_store.h"

namespace loci::cli {
namespace {

struct EvalLoopsArgs {
  std::string db, groundtruth;
  double offset_ms = 0;
  double max_gap_ms = 50;
  bool json = false;
};

struct KeyframeOdometry {
  int64_t session_row = 0;
  int segment = 0;
  int64_t t_ns = 0;
  SE3d T_odom_cam = SE3d::Identity();
};

// One loop match within an odometry segment, with both its error and the odometry's.
struct LoopPair {
  double rms_m = 0;
  double apart_s = 0;  // time between the two keyframes' images
  double loop_rot_deg = 0, loop_trans_m = 0;
  double odom_rot_deg = 0, odom_trans_m = 0;
};

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

StatusOr<std::map<int64_t, KeyframeOdometry>> ReadOdometry(server::SqliteStore* store) {
  std::map<int64_t, KeyframeOdometry> out;
  server::KeyframeScan scan;
  scan.images = false;
  LOCI_RETURN_IF_ERROR(store->ForEachKeyframe(
      0,
      [&](server::KeyframeRecord rec) {
        out[rec.id] = {rec.session_row, rec.segment, rec.t_ns, rec.T_odom_cam};
        return absl::OkStatus();
      },
      scan));
  return out;
}

// The loop matches of `store` within one session and odometry segment, against the truth.
StatusOr<std::vector<LoopPair>> CompareLoops(const EvalLoopsArgs& a, size_t* other_matches) {
  server::SqliteStoreOptions options;
  options.read_only = true;
  auto store = server::SqliteStore::Open(a.db, options);
  if (!store.ok()) return store.status();
  auto kf = ReadOdometry(store->get());
  if (!kf.ok()) return kf.status();
  auto matches = (*store)->ListPlaceMatches();
  if (!matches.ok()) return matches.status();
  auto gt = ReadTumTrajectory(a.groundtruth);
  if (!gt.ok()) return gt.status();
  std::vector<RelativePoseSample> loops, odometry;
  std::vector<double> rms_m, apart_s;
  for (const server::PlaceMatchRecord& m : *matches) {
    auto ia = kf->find(m.a_keyframe_id), ib = kf->find(m.b_keyframe_id);
    if (ia == kf->end() || ib == kf->end() || ia->second.session_row != ib->second.session_row ||
        ia->second.segment != ib->second.segment) {
      ++*other_matches;  // a merge between robots, or across a tracking loss: no odometry
      continue;
    }
    const KeyframeOdometry &ka = ia->second, &kb = ib->second;
    loops.push_back({ka.t_ns, kb.t_ns, m.T_a_b});
    odometry.push_back({ka.t_ns, kb.t_ns, ka.T_odom_cam.inverse() * kb.T_odom_cam});
    rms_m.push_back(m.rms_m);
    apart_s.push_back(std::abs(static_cast<double>(kb.t_ns - ka.t_ns)) * 1e-9);
  }
  const Trajectory sorted = SortedByTime(std::move(*gt));
  const auto offset_ns = static_cast<int64_t>(std::llround(a.offset_ms * 1e6));
  const auto gap_ns = static_cast<int64_t>(std::llround(a.max_gap_ms * 1e6));
  const RelativePoseErrors le = CompareRelativePoses(sorted, loops, offset_ns, gap_ns);
  const RelativePoseErrors oe = CompareRelativePoses(sorted, odometry, offset_ns, gap_ns);
  std::vector<LoopPair> pairs;
  for (size_t i = 0; i < loops.size(); ++i) {
    if (std::isnan(le.rot_deg[i]) || std::isnan(oe.rot_deg[i])) continue;  // no truth there
    pairs.push_back(
        {rms_m[i], apart_s[i], le.rot_deg[i], le.trans_m[i], oe.rot_deg[i], oe.trans_m[i]});
  }
  return pairs;
}

nlohmann::json Summary(const std::vector<LoopPair>& pairs) {
  std::vector<double> lr, lt, orot, ot;
  size_t odometry_closer = 0;
  for (const LoopPair& p : pairs) {
    lr.push_back(p.loop_rot_deg);
    lt.push_back(p.loop_trans_m);
    orot.push_back(p.odom_rot_deg);
    ot.push_back(p.odom_trans_m);
    odometry_closer += p.odom_rot_deg < p.loop_rot_deg;
  }
  return {{"pairs", pairs.size()},
          {"loop_rot_deg", {{"median", Quantile(lr, 0.5)}, {"p90", Quantile(lr, 0.9)}}},
          {"loop_trans_m", {{"median", Quantile(lt, 0.5)}, {"p90", Quantile(lt, 0.9)}}},
          {"odometry_rot_deg", {{"median", Quantile(orot, 0.5)}, {"p90", Quantile(orot, 0.9)}}},
          {"odometry_trans_m", {{"median", Quantile(ot, 0.5)}, {"p90", Quantile(ot, 0.9)}}},
          {"odometry_closer_in_rotation", odometry_closer}};
}

// The summaries of the pairs whose `key` falls in each band [edges[b], edges[b + 1]), each with
// its lower edge under `from_name`.
nlohmann::json Bands(const std::vector<LoopPair>& pairs, double LoopPair::*key,
                     const std::vector<double>& edges, const char* from_name) {
  nlohmann::json bands = nlohmann::json::array();
  for (size_t b = 0; b + 1 < edges.size(); ++b) {
    std::vector<LoopPair> in;
    for (const LoopPair& p : pairs) {
      if (p.*key >= edges[b] && p.*key < edges[b + 1]) in.push_back(p);
    }
    nlohmann::json s = Summary(in);
    s[from_name] = edges[b];
    bands.push_back(s);
  }
  return bands;
}

// The summary overall, per band of the match's fit RMS (m): [0, 0.01), [0.01, 0.02), 0.02+, and
// per band of the time between its keyframes (s): [0, 4), [4, 8), [8, 16), 16+. A tracker that
// holds a local map matches both ends of a short loop against the same map points, so its
// odometry there does not drift as a chain of independent steps would.
nlohmann::json Report(const std::vector<LoopPair>& pairs, size_t other_matches) {
  nlohmann::json r = Summary(pairs);
  r["other_matches"] = other_matches;
  r["by_rms"] = Bands(pairs, &LoopPair::rms_m, {0, 0.01, 0.02, INFINITY}, "rms_from_m");
  r["by_apart"] = Bands(pairs, &LoopPair::apart_s, {0, 4, 8, 16, INFINITY}, "apart_from_s");
  return r;
}

void PrintLine(const char* name, const nlohmann::json& s) {
  std::printf("%-11s %5d  %6.2f / %6.2f deg  %6.3f / %6.3f m  %6.2f / %6.2f deg  %6.3f / %6.3f m"
              "  %d\n",
              name, s["pairs"].get<int>(), s["loop_rot_deg"]["median"].get<double>(),
              s["loop_rot_deg"]["p90"].get<double>(), s["loop_trans_m"]["median"].get<double>(),
              s["loop_trans_m"]["p90"].get<double>(), s["odometry_rot_deg"]["median"].get<double>(),
              s["odometry_rot_deg"]["p90"].get<double>(),
              s["odometry_trans_m"]["median"].get<double>(),
              s["odometry_trans_m"]["p90"].get<double>(),
              s["odometry_closer_in_rotation"].get<int>());
}

void PrintText(const nlohmann::json& r) {
  std::printf("loop matches within one odometry segment, against the ground truth "
              "(median / p90); %d other matches (merges, across a tracking loss)\n",
              r["other_matches"].get<int>());
  std::printf("%-11s %5s  %-19s  %-19s  %-19s  %-19s  %s\n", "", "pairs", "loop rotation",
              "loop translation", "odometry rotation", "odometry translation",
              "odometry closer");
  PrintLine("all", r);
  const char* rms_names[] = {"rms < 1 cm", "rms 1-2 cm", "rms >= 2 cm"};
  for (int b = 0; b < 3; ++b) PrintLine(rms_names[b], r["by_rms"][b]);
  const char* apart_names[] = {"< 4 s", "4-8 s", "8-16 s", ">= 16 s"};
  for (int b = 0; b < 4; ++b) PrintLine(apart_names[b], r["by_apart"][b]);
}

void RunEvalLoops(const EvalLoopsArgs& a) {
  size_t other_matches = 0;
  auto pairs = CompareLoops(a, &other_matches);
  if (!pairs.ok()) {
    std::cerr << "error: " << pairs.status().message() << "\n";
    ExitCode() = 1;
    return;
  }
  if (pairs->empty()) {
    std::cerr << "error: no loop match in " << a.db << " has ground truth at both keyframes\n";
    ExitCode() = 1;
    return;
  }
  const nlohmann::json r = Report(*pairs, other_matches);
  if (a.json) {
    std::cout << r.dump(2) << "\n";
  } else {
    PrintText(r);
  }
}

}  // namespace

void RegisterEvalLoopsCommand(CLI::App& app) {
  CLI::App* eval = EvalGroup(app);
  auto args = std::make_shared<EvalLoopsArgs>();
  CLI::App* c = eval->add_subcommand(
      "loops", "A server's verified loop matches and the odometry between the same keyframes, "
               "against the ground truth");
  c->add_option("--db", args->db, "the server's SQLite database")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--groundtruth", args->groundtruth, "ground-truth TUM trajectory")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--offset-ms", args->offset_ms,
                "added to the keyframes' stamps before reading the truth (an image clock's "
                "offset), ms")
      ->capture_default_str();
  c->add_option("--max-gap-ms", args->max_gap_ms,
                "longest ground-truth gap to interpolate across, ms")
      ->capture_default_str();
  c->add_flag("--json", args->json, "print JSON instead of text");
  c->callback([args] { RunEvalLoops(*args); });
}

}  // namespace loci::cli
