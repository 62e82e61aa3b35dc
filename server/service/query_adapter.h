// The query engine (query/) behind the server's Ask rpc: reads the map (objects, up direction,
// latest robot poses), indexes it once per map version and converts AskResult to AskResponse.
//
//   auto adapter = std::make_shared<QueryAdapter>(QueryAdapterOptions{});
//   auto grpc = GrpcServer::Start(&map_server, "127.0.0.1:0", 64, adapter);
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/status.h"
#include "query/query_engine.h"
#include "server/map/mapper.h"
#include "server/map/up_estimate.h"
#include "server/service/query_engine.h"

namespace loci::server {

// What the adapter reads from a map. MapServer's mapper is one source; benchmarks and tests
// supply fixed maps through the same path.
class QueryMapSource {
 public:
  virtual ~QueryMapSource() = default;
  // Latest camera pose per robot; changes with every integrated keyframe, so it also serves as
  // the map's version (see QueryAdapter).
  virtual std::map<std::string, RobotPose> LatestPoses() const = 0;
  virtual std::vector<MapObject> Objects(bool confirmed_only) const = 0;
  // Objects found gone, with their history (none by default).
  virtual std::vector<MapObject> Removed() const { return {}; }
  // Up from the clients' gravity (unit, map frame), if any client sent it.
  virtual std::optional<Vec3d> GravityUp() const = 0;
  // Map cloud at `voxel_m` for the plane-based up estimate (map frame, metres).
  virtual std::vector<Eigen::Vector3f> CloudPoints(double voxel_m) const = 0;
  // Extra version salt for sources whose poses do not change (0 for the mapper).
  virtual uint64_t VersionSalt() const { return 0; }
  // How the source's map frame was levelled ("" = not levelled: up is estimated here).
  virtual std::string LevelledBy() const { return ""; }
};

// A source that reads the running server's Mapper, or an island's (island_maps.h: its objects
// carry the island's name).
class MapperSource final : public QueryMapSource {
 public:
  explicit MapperSource(const Mapper& mapper, std::string island = "")
      : mapper_(mapper), island_(std::move(island)) {}
  std::map<std::string, RobotPose> LatestPoses() const override { return mapper_.LatestPoses(); }
  std::vector<MapObject> Objects(bool confirmed_only) const override;
  std::vector<MapObject> Removed() const override;
  std::optional<Vec3d> GravityUp() const override { return mapper_.UpDirection(); }
  std::vector<Eigen::Vector3f> CloudPoints(double voxel_m) const override;
  std::string LevelledBy() const override { return mapper_.FrameSource(); }

 private:
  const Mapper& mapper_;
  const std::string island_;
};

struct QueryAdapterOptions {
  query::QueryOptions query = query::QueryOptions::Defaults();  // engine options
  // Ask sees confirmed objects only (candidates seen in < 3 keyframes stay out). Default true.
  bool confirmed_only = true;
  // Longest accepted question, bytes (4096): longer text is INVALID_ARGUMENT before parsing.
  size_t max_question_bytes = 4096;
  // Plane-based up estimate (server/map/up_estimate.h): refines the map's gravity, or gives the
  // up when no client sent gravity.
  PlaneUpOptions up_planes;
  // When clients sent gravity, the plane estimate replaces it if within this angle (deg, 5).
  double up_refine_max_deg = 5.0;
  // An up within this angle of the map's +z is taken as +z (deg, 1): sub-degree tilts are
  // accelerometer bias and the robots' own accelerations, and only an exactly vertical up lets
  // the engine use the mapper's axis-aligned boxes (tilted PCA boxes otherwise; see .cc).
  double up_snap_deg = 1.0;
  // Clock for "last seen N s ago" (ns since the epoch); null = wall clock. Tests fix it.
  std::function<int64_t()> now_ns;
  // Recorded data: when the newest keyframe of the map is older than this (s, 3600) on that
  // clock, ages are told relative to the newest keyframe ("map time") instead, so a replayed
  // 2011 TUM sequence reads "last seen 12 s ago", not "5673 days ago".
  double replay_age_s = 3600.0;
};

// Gives the query the class priors of the map it answers on (config/classes.yaml `stand_m`): its
// "on" allows for the stand under a monitor, whose points the map leaves out.
void UseMapClassPriors(const MapOptions& map, QueryAdapterOptions* options);

class QueryAdapter final : public QueryEngine {
 public:
  explicit QueryAdapter(QueryAdapterOptions options);

  // The shared map's answer; then, for each map island (sessions not aligned yet) whose own
  // answer names objects, a sentence "In the island of robot R (...): ANSWER" and its objects
  // (Object.island set). Relations are only found within one map.
  StatusOr<loci::v1::AskResponse> Ask(const loci::v1::AskRequest& request,
                                      const MapServer& server) override;
  // Same on any map source; `slot` names the source's cached index ("" = the shared map's).
  // Thread-safe. INVALID_ARGUMENT for a question that is too long, not UTF-8, or not understood
  // (the message lists the known words).
  StatusOr<loci::v1::AskResponse> Ask(const loci::v1::AskRequest& request,
                                      const QueryMapSource& source, const std::string& slot = "");

  // Where the last index's up direction came from: "map frame (HOW)" for the server's levelled
  // map, else "gravity+planes" (gravity refined by the horizontal planes), "gravity", "planes"
  // or "config".
  std::string up_source() const;
  // Index builds so far (tests: the cache holds per map version).
  uint64_t index_builds() const;

 private:
  std::shared_ptr<const query::MapIndex> IndexFor(const QueryMapSource& source,
                                                  const std::string& slot);
  // Forgets the cached indexes of islands that no longer exist.
  void KeepSlots(const std::vector<std::string>& islands);
  // Up of a source whose map is not levelled: its gravity refined by planes, else planes, else
  // the configured up; snapped to +z within up_snap_deg.
  void EstimateUp(const QueryMapSource& source, std::optional<Vec3d>* up,
                  std::string* up_source) const;

  QueryAdapterOptions options_;
  query::QueryEngine engine_;
  mutable std::mutex mu_;  // guards the cache fields below
  struct CachedIndex {
    std::string key;
    std::shared_ptr<const query::MapIndex> index;
  };
  std::map<std::string, CachedIndex> cache_;  // by slot: "" = the shared map, else an island
  std::string up_source_ = "config";
  uint64_t builds_ = 0;
  // One build at a time; askers meanwhile use the previous index (or wait when there is none).
  std::mutex build_mu_;
};

// Converts an engine answer to the wire message (its status is not part of it: the caller
// returns a failed result as the call's status).
loci::v1::AskResponse ToProto(const query::AskResult& result);

// For evaluation tools that print an answer line either way: the response, or one whose answer
// is "(error: MESSAGE)" (as they show a failed Ask over gRPC).
loci::v1::AskResponse AnswerOrError(const StatusOr<loci::v1::AskResponse>& answer);

}  // namespace loci::server
