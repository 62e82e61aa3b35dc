#include "cli/report/synth_changes_eval.h"

#include <absl/strings/str_cat.h>
#include <absl/strings/str_format.h>

#include <algorithm>
#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>

#include "client/app/track_pipeline.h"
#include "common/config.h"
#include "common/detections_io.h"
#include "common/objects_json.h"
#include "common/tum_io.h"
#include "server/map/mapper.h"
#include "server/map/visibility.h"
#include "server/runtime/server_options.h"
#include "synth/scene.h"
#include "synth/sequence_writer.h"

namespace loci::report {
namespace {

using Kind = ObjectPlaceChange::Kind;
constexpr int64_t kSessionGapNs = 2 * 86400 * 1'000'000'000LL;  // sessions two days apart
constexpr double kMatchM = 0.3;  // a reported change is at a true one's place within this

// The objects that change: A moved in session 2, B gone in session 2, C new in session 3, D
// moved in session 3. Movable things only: no furniture something rests on, no walker, a
// class the server maps.
struct Picks {
  int64_t a = 0, b = 0, c = 0, d = 0;
};

StatusOr<Picks> PickChanges(const synth::SceneOptions& base, const server::MapOptions& map,
                            int attempt) {
  LOCI_ASSIGN_OR_RETURN(synth::Scene scene, synth::MakeScene(base));
  std::set<int64_t> supports;
  for (const synth::SceneObject& o : scene.objects) supports.insert(o.on_id);
  std::vector<int64_t> movable;
  for (const synth::SceneObject& o : scene.objects) {
    const bool mapped = std::count(map.mapped_classes.begin(), map.mapped_classes.end(),
                                   o.class_name) > 0;
    if (!o.dynamic && mapped && !map.IsDynamic(o.class_name) && !supports.count(o.id)) {
      movable.push_back(o.id);
    }
  }
  if (movable.size() < 4) {
    return absl::FailedPreconditionError(
        absl::StrCat("seed ", base.seed, ": fewer than 4 movable objects"));
  }
  std::mt19937_64 rng(base.seed * 0x9E3779B97F4A7C15ull + 0xC4A9 + attempt);
  std::shuffle(movable.begin(), movable.end(), rng);
  return Picks{movable[0], movable[1], movable[2], movable[3]};
}

// A mapped keyframe as the visibility test reads it (world frame = the scene's).
struct SessionView {
  SE3d T_world_cam;
  cv::Mat depth_m;
  PinholeCamera camera;
};

// Maps one session folder into `mapper` with the scene's poses, every n-th frame; keeps the
// views.
Status MapSession(const std::string& dir, int session, int every_nth, int64_t* keyframe_id,
                  server::Mapper* mapper, std::vector<SessionView>* views) {
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(dir));
  LOCI_ASSIGN_OR_RETURN(ClientConfig config, LoadClientConfig("", dir));
  LOCI_ASSIGN_OR_RETURN(auto detections, ReadDetectionsJsonl(dir + "/detections.jsonl"));
  for (size_t i = 0; i < seq.frames.size(); i += every_nth) {
    const TumFrame& f = seq.frames[i];
    const StampedPose* pose =
        NearestByTime<StampedPose>(seq.groundtruth, f.rgb_t_ns, 1'000'000);
    if (pose == nullptr) return absl::NotFoundError(dir + ": a frame has no pose");
    server::MapperKeyframe mk;
    mk.keyframe_id = ++*keyframe_id;
    mk.session_row = session;
    mk.robot = "bench";
    mk.t_ns = f.rgb_t_ns;
    mk.T_base_kf = pose->T_world_cam;
    mk.T_odom_kf = pose->T_world_cam;
    mk.camera = config.tracker.camera;
    mk.bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    const cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (mk.bgr.empty() || depth.empty()) return absl::DataLossError(dir + ": unreadable image");
    depth.convertTo(mk.depth_m, CV_32F, 1.0 / config.tracker.depth_scale);
    if (const FrameDetections* fd = FindDetections(detections, f.rgb_t_ns)) {
      mk.detections = fd->detections;
    }
    if (!seq.accel.empty()) {
      if (auto g = GravityInCamAt(seq.accel, f.rgb_t_ns); g.ok()) {
        mk.has_gravity = true;
        mk.gravity_cam = *g;
      }
    }
    views->push_back({pose->T_world_cam, mk.depth_m, mk.camera});
    mapper->Integrate(mk);
  }
  return absl::OkStatus();
}

// One change as the map reports it, or as it happened (map frame).
struct Change {
  Kind kind = Kind::kAppeared;
  std::string class_name;
  Vec3d at_m = Vec3d::Zero(), from_m = Vec3d::Zero();
};

// The changes the map holds with a time in [t0_ns, t1_ns): moves, removals, first appearances.
std::vector<Change> Reported(const server::Mapper& mapper, int64_t t0_ns, int64_t t1_ns) {
  std::vector<Change> out;
  auto in = [&](int64_t t) { return t >= t0_ns && t < t1_ns; };
  for (const MapObject& o : mapper.Snapshot(true)) {
    for (size_t i = 0; i < o.history.size(); ++i) {
      const ObjectPlaceChange& c = o.history[i];
      if (!in(c.t_ns) || (c.kind == Kind::kAppeared && i > 0)) continue;
      out.push_back({c.kind, o.class_name, c.centroid_m, c.from_m});
    }
  }
  for (const MapObject& o : mapper.Removed()) {
    if (!o.history.empty() && in(o.history.back().t_ns)) {
      out.push_back({Kind::kRemoved, o.class_name, o.history.back().from_m,
                     o.history.back().from_m});
    }
  }
  return out;
}

bool Matches(const Change& reported, const Change& truth) {
  if (reported.kind != truth.kind || reported.class_name != truth.class_name) return false;
  const bool at = (reported.at_m - truth.at_m).norm() < kMatchM;
  const bool from = (reported.from_m - truth.from_m).norm() < kMatchM;
  switch (truth.kind) {
    case Kind::kAppeared: return at;
    case Kind::kMoved: return at && from;
    case Kind::kRemoved: return from;
  }
  return false;
}

struct SessionTruth {
  std::vector<Change> changes;   // what happened
  std::vector<Change> excluded;  // changes of barely seen objects: neither found nor false
  int unobservable = 0;          // of them, changes whose old place the session never showed
};

const GroundTruthObject* FindGt(const GroundTruthScene& s, int64_t id) {
  for (const GroundTruthObject& o : s.objects) {
    if (o.id == id) return &o;
  }
  return nullptr;
}

// Keyframes of the session that should have shown the object's box (the map's own
// visibility test on its centre and shrunk corners): a place never in view cannot be seen
// empty.
int ViewsShowing(const GroundTruthObject& o, const std::vector<SessionView>& views,
                 const server::VisibilityOptions& options) {
  std::vector<Eigen::Vector3d> sample = {o.centroid_m};
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1) ? o.aabb_max_m.x() : o.aabb_min_m.x(),
                                 (i & 2) ? o.aabb_max_m.y() : o.aabb_min_m.y(),
                                 (i & 4) ? o.aabb_max_m.z() : o.aabb_min_m.z());
    sample.push_back(o.centroid_m + 0.75 * (corner - o.centroid_m));
  }
  const std::vector<Detection2D> none;
  int n = 0;
  for (const SessionView& v : views) {
    const server::KeyframeView view{&v.camera, &v.depth_m, 1, v.T_world_cam.inverse(), &none};
    n += server::ExpectedInView(sample, 0.5 * o.extent_m.maxCoeff(), view, options);
  }
  return n;
}

constexpr int kMinViews = 3;  // views of an empty place needed before it can be called empty

// A true change of object `id` from scene `before` to `after` (nullptr: not in it), excluded
// when the object is barely seen or its old place never in the session's view.
void AddTruth(Kind kind, int64_t id, const GroundTruthScene* before, const GroundTruthScene* after,
              const SE3d& T_map_world, const std::vector<SessionView>& views,
              const server::VisibilityOptions& visibility, SessionTruth* truth) {
  const GroundTruthObject* b = before ? FindGt(*before, id) : nullptr;
  const GroundTruthObject* a = after ? FindGt(*after, id) : nullptr;
  const GroundTruthObject* any = a ? a : b;
  if (any == nullptr) return;
  Change c;
  c.kind = kind;
  c.class_name = any->class_name;
  if (a) c.at_m = T_map_world * a->centroid_m;
  if (b) c.from_m = T_map_world * b->centroid_m;
  const bool low = (a && a->confidence == "low") || (b && b->confidence == "low");
  const bool unseen_place = b != nullptr && ViewsShowing(*b, views, visibility) < kMinViews;
  truth->unobservable += !low && unseen_place;
  (low || unseen_place ? truth->excluded : truth->changes).push_back(c);
}

// Objects barely seen in the session before: the map may confirm them only now.
void ExcludeBarelySeen(const GroundTruthScene& before, const SE3d& T_map_world,
                       SessionTruth* truth) {
  for (const GroundTruthObject& o : before.objects) {
    if (o.confidence != "low") continue;
    truth->excluded.push_back({Kind::kAppeared, o.class_name, T_map_world * o.centroid_m, {}});
  }
}

std::string Describe(const Change& c) {
  auto at = [](const Vec3d& p) {
    return absl::StrFormat("(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
  };
  switch (c.kind) {
    case Kind::kAppeared: return absl::StrCat("new ", c.class_name, " at ", at(c.at_m));
    case Kind::kMoved:
      return absl::StrCat("moved ", c.class_name, " from ", at(c.from_m), " to ", at(c.at_m));
    case Kind::kRemoved: return absl::StrCat("gone ", c.class_name, " from ", at(c.from_m));
  }
  return "";
}

void Score(int session, const std::vector<Change>& reported, const SessionTruth& truth,
           SynthChangesResult* r) {
  r->true_changes += static_cast<int>(truth.changes.size());
  for (const Change& t : truth.changes) {
    const bool found = std::any_of(reported.begin(), reported.end(),
                                   [&](const Change& c) { return Matches(c, t); });
    r->found += found;
    if (!found) r->notes.push_back(absl::StrCat("session ", session, ": missed ", Describe(t)));
  }
  for (const Change& c : reported) {
    auto match = [&](const Change& t) { return Matches(c, t); };
    if (std::none_of(truth.changes.begin(), truth.changes.end(), match) &&
        std::none_of(truth.excluded.begin(), truth.excluded.end(), match)) {
      ++r->false_changes;
      r->notes.push_back(absl::StrCat("session ", session, ": false ", Describe(c)));
    }
  }
}

}  // namespace

StatusOr<SynthChangesResult> EvaluateSynthChanges(const SynthChangesOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  server::ServerOptions sopt;
  LOCI_RETURN_IF_ERROR(sopt.FromYamlFile(
      o.server_config.empty() ? SourceDir() + "/config/server.yaml" : o.server_config));
  synth::SceneOptions base;
  base.seed = o.seed;
  base.num_frames = o.frames;
  base.num_objects = o.max_objects;
  base.varied_layout = true;
  base.depth_noise = true;
  base.detector_noise = o.detector_noise;
  // Objects whose new place fits on their support (another draw when one does not).
  Picks p;
  for (int attempt = 0;; ++attempt) {
    LOCI_ASSIGN_OR_RETURN(p, PickChanges(base, sopt.map, attempt));
    synth::SceneOptions last = base;
    last.moved_ids = {p.a, p.d};
    if (synth::MakeScene(last).ok()) break;
    if (attempt == 9) return absl::FailedPreconditionError("no two objects can be moved");
  }
  const std::vector<std::pair<std::vector<int64_t>, std::vector<int64_t>>> edits = {
      {{p.c}, {}}, {{p.b, p.c}, {p.a}}, {{p.b}, {p.a, p.d}}};  // (absent, moved) per session
  std::vector<GroundTruthScene> truth;
  std::vector<std::string> dirs;
  for (size_t k = 0; k < edits.size(); ++k) {
    synth::SceneOptions s = base;
    s.start_t_ns += static_cast<int64_t>(k) * kSessionGapNs;
    s.absent_ids = edits[k].first;
    s.moved_ids = edits[k].second;
    dirs.push_back(absl::StrCat(o.work_dir, "/seed-", o.seed, "/session-", k + 1));
    LOCI_RETURN_IF_ERROR(synth::WriteSequence(s, dirs.back()));
    LOCI_ASSIGN_OR_RETURN(GroundTruthScene gt, ReadObjectsJson(dirs.back() + "/objects.json"));
    truth.push_back(std::move(gt));
  }
  server::Mapper mapper(sopt.map);
  int64_t keyframe_id = 0;
  SynthChangesResult r;
  r.seed = o.seed;
  for (const GroundTruthObject& g : truth[0].objects) r.objects += g.dynamic ? 0 : 1;
  for (size_t k = 0; k < dirs.size(); ++k) {
    std::vector<SessionView> views;
    LOCI_RETURN_IF_ERROR(MapSession(dirs[k], static_cast<int>(k) + 1, o.every_nth, &keyframe_id,
                                    &mapper, &views));
    if (k == 0) continue;
    const SE3d T_map_world = mapper.MapFromBaseFrame();
    const server::VisibilityOptions& vis = sopt.map.fusion.visibility;
    SessionTruth st;
    if (k == 1) {
      AddTruth(Kind::kMoved, p.a, &truth[0], &truth[1], T_map_world, views, vis, &st);
      AddTruth(Kind::kRemoved, p.b, &truth[0], nullptr, T_map_world, views, vis, &st);
    } else {
      AddTruth(Kind::kAppeared, p.c, nullptr, &truth[2], T_map_world, views, vis, &st);
      AddTruth(Kind::kMoved, p.d, &truth[1], &truth[2], T_map_world, views, vis, &st);
    }
    r.unobservable += st.unobservable;
    ExcludeBarelySeen(truth[k - 1], T_map_world, &st);
    const int64_t start_ns = base.start_t_ns + static_cast<int64_t>(k) * kSessionGapNs;
    Score(static_cast<int>(k) + 1, Reported(mapper, start_ns, start_ns + kSessionGapNs), st, &r);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace loci::report
