#include "server/service/query_adapter.h"

#include <absl/strings/str_cat.h>
#include <absl/strings/str_join.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "common/time.h"
#include "server/runtime/map_server.h"
#include "server/runtime/proto_convert.h"

namespace loci::server {
namespace {

// True when `s` is well-formed UTF-8 (proto3 strings must be; answers echo question words).
bool IsValidUtf8(const std::string& s) {
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    int n = 0;
    if (c < 0x80) {
      n = 0;
    } else if ((c >> 5) == 0x6) {
      n = 1;
    } else if ((c >> 4) == 0xE) {
      n = 2;
    } else if ((c >> 3) == 0x1E) {
      n = 3;
    } else {
      return false;
    }
    if (n > 0 && i + n >= s.size()) return false;
    for (int k = 1; k <= n; ++k) {
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 0x2) return false;
    }
    i += n + 1;
  }
  return true;
}

}  // namespace

std::vector<MapObject> MapperSource::Objects(bool confirmed_only) const {
  std::vector<MapObject> objects = mapper_.Snapshot(confirmed_only);
  for (MapObject& o : objects) o.island = island_;
  return objects;
}

std::vector<MapObject> MapperSource::Removed() const {
  std::vector<MapObject> objects = mapper_.Removed();
  for (MapObject& o : objects) o.island = island_;
  return objects;
}

std::vector<Eigen::Vector3f> MapperSource::CloudPoints(double voxel_m) const {
  std::vector<Eigen::Vector3f> out;
  for (const SemanticPoint& p : mapper_.Cloud(voxel_m, {})) out.push_back(p.p_m);
  return out;
}

loci::v1::AskResponse ToProto(const query::AskResult& result) {
  loci::v1::AskResponse out;
  out.set_answer(result.answer);
  for (const MapObject& o : result.objects) ToProto(o, out.add_objects());
  for (const query::RelationResult& r : result.relations) {
    loci::v1::Relation* rel = out.add_relations();
    rel->set_name(std::string(query::RelationName(r.kind)));
    rel->set_subject_id(r.subject_id);
    rel->set_anchor_id(r.anchor_id);
    rel->set_confidence(r.confidence);
    rel->set_evidence(r.evidence);
  }
  out.set_count(result.count);
  out.set_intent(result.intent);
  return out;
}

loci::v1::AskResponse AnswerOrError(const StatusOr<loci::v1::AskResponse>& answer) {
  if (answer.ok()) return *answer;
  loci::v1::AskResponse out;
  out.set_answer(absl::StrCat("(error: ", answer.status().message(), ")"));
  return out;
}

void UseMapClassPriors(const MapOptions& map, QueryAdapterOptions* options) {
  options->query.relations.on_stand_m = map.stand_m;
}

QueryAdapter::QueryAdapter(QueryAdapterOptions options)
    : options_(std::move(options)), engine_(options_.query) {}

StatusOr<loci::v1::AskResponse> QueryAdapter::Ask(const loci::v1::AskRequest& request,
                                                  const MapServer& server) {
  LOCI_ASSIGN_OR_RETURN(loci::v1::AskResponse answer, Ask(request, MapperSource(server.mapper())));
  if (server.islands() == nullptr) return answer;
  std::vector<std::string> names;
  for (const IslandMaps::Island& island : server.islands()->List()) {
    names.push_back(island.name);
    StatusOr<loci::v1::AskResponse> in_island =
        Ask(request, MapperSource(*island.map, island.name), island.name);
    if (!in_island.ok() || in_island->objects().empty()) continue;
    // Before: what the shared map says, or that it has none of it.
    const std::string before =
        answer.objects().empty() ? "Not in the shared map." : answer.answer() + " Also";
    answer.set_answer(absl::StrCat(
        before, answer.objects().empty() ? " In" : " in", " the island of robot",
        island.robots.size() > 1 ? "s " : " ", absl::StrJoin(island.robots, ", "), " (",
        island.name, ", not aligned with the shared map yet; positions in its own frame): ",
        in_island->answer()));
    for (const loci::v1::Object& o : in_island->objects()) *answer.add_objects() = o;
    for (const loci::v1::Relation& r : in_island->relations()) *answer.add_relations() = r;
  }
  KeepSlots(names);
  return answer;
}

void QueryAdapter::KeepSlots(const std::vector<std::string>& islands) {
  std::lock_guard<std::mutex> lock(mu_);
  std::erase_if(cache_, [&](const auto& entry) {
    return !entry.first.empty() &&
           std::find(islands.begin(), islands.end(), entry.first) == islands.end();
  });
}

StatusOr<loci::v1::AskResponse> QueryAdapter::Ask(const loci::v1::AskRequest& request,
                                                  const QueryMapSource& source,
                                                  const std::string& slot) {
  const std::string& text = request.text();
  if (text.size() > options_.max_question_bytes) {
    return absl::InvalidArgumentError(absl::StrCat("question is ", text.size(),
                                                   " bytes long; at most ",
                                                   options_.max_question_bytes, " are accepted"));
  }
  if (!IsValidUtf8(text) || !IsValidUtf8(request.robot_name())) {
    return absl::InvalidArgumentError("question and robot name must be UTF-8 text");
  }
  const std::shared_ptr<const query::MapIndex> index = IndexFor(source, slot);
  int64_t now_ns = options_.now_ns ? options_.now_ns() : NowNs();
  int64_t newest_kf_ns = 0;
  for (const auto& [robot, pose] : source.LatestPoses()) {
    newest_kf_ns = std::max(newest_kf_ns, pose.t_ns);
  }
  if (newest_kf_ns > 0 && now_ns - newest_kf_ns > SecondsToNs(options_.replay_age_s)) {
    now_ns = newest_kf_ns;
  }
  const query::AskResult result =
      engine_.Ask(text, *index, query::AskContext{now_ns, request.robot_name()});
  if (!result.status.ok()) return result.status;
  return ToProto(result);
}

void QueryAdapter::EstimateUp(const QueryMapSource& source, std::optional<Vec3d>* up,
                              std::string* up_source) const {
  // Gravity from accelerometers is tilted by the robots' own accelerations (~1 deg), enough to
  // sink a cup into a 1.6 m table top in the gravity frame; floor and table-top planes give the
  // direction to a fraction of a degree. So: planes near gravity refine it; without gravity
  // planes near the configured up give it; else the configured up.
  const std::optional<Vec3d> gravity = source.GravityUp();
  const Vec3d prior = gravity ? *gravity : options_.query.default_up_map;
  const std::optional<Vec3d> planes = EstimateUpFromPlanes(
      source.CloudPoints(options_.up_planes.voxel_m), prior, options_.up_planes);
  if (gravity) {
    const bool refine =
        planes && planes->dot(*gravity) >= std::cos(options_.up_refine_max_deg * M_PI / 180.0);
    *up = refine ? *planes : *gravity;
    *up_source = refine ? "gravity+planes" : "gravity";
  } else {
    *up = planes ? *planes : options_.query.default_up_map;
    *up_source = planes ? "planes" : "config";
  }
  // Snap a near-vertical up to the map's +z: the engine then measures relations on the
  // mapper's axis-aligned boxes; for any other up it turns to the PCA boxes, which tilt with a
  // table's legs and would sink the objects on it.
  if ((*up)->normalized().dot(Vec3d::UnitZ()) >= std::cos(options_.up_snap_deg * M_PI / 180.0)) {
    *up = Vec3d::UnitZ();
  }
}

std::shared_ptr<const query::MapIndex> QueryAdapter::IndexFor(const QueryMapSource& source,
                                                              const std::string& slot) {
  // Version key: every integrated keyframe moves its robot's latest pose stamp. Read before the
  // snapshot, so a keyframe landing in between only makes the next Ask rebuild.
  const std::map<std::string, RobotPose> poses = source.LatestPoses();
  std::string key = absl::StrCat(source.VersionSalt(), "|");
  for (const auto& [robot, pose] : poses) absl::StrAppend(&key, robot, "@", pose.t_ns, ";");
  auto cached = [&](bool any_version) -> std::shared_ptr<const query::MapIndex> {
    auto it = cache_.find(slot);  // mu_ held
    if (it == cache_.end() || !(any_version || it->second.key == key)) return nullptr;
    return it->second.index;
  };
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto index = cached(false)) return index;
  }
  // While another asker rebuilds, answer from the index at hand (a keyframe older) rather
  // than queue behind the build: under ingest, builds would otherwise set the tail latency.
  std::unique_lock<std::mutex> build_lock(build_mu_, std::try_to_lock);
  if (!build_lock.owns_lock()) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (auto index = cached(true)) return index;
    }
    build_lock.lock();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);  // another asker may have built it meanwhile
    if (auto index = cached(false)) return index;
  }
  // The server's map frame is levelled when it is built (server/map/map_frame.h): its z is up.
  const std::string levelled = source.LevelledBy();
  std::optional<Vec3d> up;
  std::string up_source;
  if (!levelled.empty()) {
    up = Vec3d::UnitZ();
    up_source = "map frame (" + levelled + ")";
  } else {
    EstimateUp(source, &up, &up_source);
  }
  std::vector<query::Viewpoint> viewpoints;
  for (const auto& [robot, pose] : poses) viewpoints.push_back({robot, pose.T_map_cam, pose.t_ns});
  auto index = engine_.Index(source.Objects(options_.confirmed_only), up, std::move(viewpoints),
                             source.Removed());
  std::lock_guard<std::mutex> lock(mu_);
  cache_[slot] = CachedIndex{std::move(key), index};
  if (slot.empty()) up_source_ = up_source;
  ++builds_;
  return index;
}

std::string QueryAdapter::up_source() const {
  std::lock_guard<std::mutex> lock(mu_);
  return up_source_;
}

uint64_t QueryAdapter::index_builds() const {
  std::lock_guard<std::mutex> lock(mu_);
  return builds_;
}

}  // namespace loci::server
