// gRPC services of a read-only query server (`loci-server --read-only`): the Query service over
// the map a site's writer publishes (server/runtime/replica_map.h), and a Mapping service that
// sends robots to that writer. Objects, questions, stats and object events (the changes between
// consecutive publications, replica_changes.h) are answered here; the cloud, the OctoMap and
// trajectories stay with the writer, which holds them.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/runtime/replica_map.h"
#include "server/service/auth.h"
#include "server/service/query_api.h"
#include "server/service/query_adapter.h"

namespace loci::server {

// The address of the site's writer ("host:port"), "" when none holds the lease now.
using WriterAddress = std::function<std::string()>;

// A published map as the query engine reads it.
class PublishedSource final : public QueryMapSource {
 public:
  explicit PublishedSource(std::shared_ptr<const ReplicaSnapshot> s) : s_(std::move(s)) {}
  std::map<std::string, RobotPose> LatestPoses() const override { return s_->poses; }
  std::vector<MapObject> Objects(bool confirmed_only) const override;
  std::vector<MapObject> Removed() const override { return s_->removed; }
  std::optional<Vec3d> GravityUp() const override { return s_->up_map; }
  // The writer publishes no cloud: without a levelled frame the up is gravity or the config's.
  std::vector<Eigen::Vector3f> CloudPoints(double) const override { return {}; }
  uint64_t VersionSalt() const override { return static_cast<uint64_t>(s_->version); }
  std::string LevelledBy() const override { return s_->levelled_by; }

 private:
  std::shared_ptr<const ReplicaSnapshot> s_;
};

class ReadOnlyQueryService final : public loci::v1::Query::Service, public QueryApi {
 public:
  // All outlive the service. Every gRPC call needs a caller that may read (auth.h); the HTTP
  // API authenticates its own requests and calls the QueryApi methods.
  ReadOnlyQueryService(ReplicaMap* map, std::shared_ptr<QueryAdapter> engine,
                       const Authorizer* auth, WriterAddress writer, MapStore* store)
      : map_(map), engine_(std::move(engine)), auth_(auth), writer_(std::move(writer)),
        store_(store) {}

  grpc::Status Ask(const loci::v1::AskRequest& req, loci::v1::AskResponse* resp) override;
  grpc::Status FindObjects(const loci::v1::FindObjectsRequest& req,
                           loci::v1::FindObjectsResponse* resp) override;
  // Without the cloud and keyframes (with_cloud: FAILED_PRECONDITION naming the writer).
  grpc::Status GetObject(const loci::v1::GetObjectRequest& req,
                         loci::v1::GetObjectResponse* resp) override;
  // Sessions, keyframes and database size from the store; objects from the published map.
  grpc::Status GetStats(loci::v1::GetStatsResponse* resp) override;
  // FAILED_PRECONDITION naming the writer: these are served where the map is built.
  grpc::Status GetCloud(const loci::v1::GetCloudRequest& req,
                        loci::v1::GetCloudResponse* resp) override;
  grpc::Status GetTrajectories(const loci::v1::GetTrajectoriesRequest& req,
                               loci::v1::GetTrajectoriesResponse* resp) override;
  Status SubscribeObjects(std::shared_ptr<ObjectEventQueue> queue) override;
  void UnsubscribeObjects(const std::shared_ptr<ObjectEventQueue>& queue) override;

  grpc::Status Ask(grpc::ServerContext* ctx, const loci::v1::AskRequest* req,
                   loci::v1::AskResponse* resp) override;
  grpc::Status FindObjects(grpc::ServerContext* ctx, const loci::v1::FindObjectsRequest* req,
                           loci::v1::FindObjectsResponse* resp) override;
  grpc::Status GetObject(grpc::ServerContext* ctx, const loci::v1::GetObjectRequest* req,
                         loci::v1::GetObjectResponse* resp) override;
  grpc::Status GetStats(grpc::ServerContext* ctx, const loci::v1::GetStatsRequest* req,
                        loci::v1::GetStatsResponse* resp) override;
  grpc::Status GetCloud(grpc::ServerContext* ctx, const loci::v1::GetCloudRequest* req,
                        loci::v1::GetCloudResponse* resp) override;
  grpc::Status GetOctomap(grpc::ServerContext* ctx, const loci::v1::GetOctomapRequest* req,
                          loci::v1::GetOctomapResponse* resp) override;
  grpc::Status GetTrajectories(grpc::ServerContext* ctx,
                               const loci::v1::GetTrajectoriesRequest* req,
                               loci::v1::GetTrajectoriesResponse* resp) override;
  // The changes of each publication loaded after the call (ReplicaMap::events).
  grpc::Status WatchObjects(grpc::ServerContext* ctx, const loci::v1::WatchObjectsRequest* req,
                            grpc::ServerWriter<loci::v1::ObjectEvent>* writer) override;

 private:
  // The map is loaded: the snapshot to answer from.
  grpc::Status Loaded(std::shared_ptr<const ReplicaSnapshot>* snapshot) const;
  grpc::Status AtWriter(const std::string& what) const;

  ReplicaMap* const map_;
  const std::shared_ptr<QueryAdapter> engine_;
  const Authorizer* const auth_;
  const WriterAddress writer_;
  MapStore* const store_;
};

// Refuses every Mapping call with FAILED_PRECONDITION naming the site's writer.
class ReadOnlyMappingService final : public loci::v1::Mapping::Service {
 public:
  ReadOnlyMappingService(std::string site, WriterAddress writer)
      : site_(std::move(site)), writer_(std::move(writer)) {}
  grpc::Status OpenSession(grpc::ServerContext* ctx, const loci::v1::OpenSessionRequest* req,
                           loci::v1::OpenSessionResponse* resp) override;
  grpc::Status StreamKeyframes(
      grpc::ServerContext* ctx,
      grpc::ServerReaderWriter<loci::v1::KeyframeAck, loci::v1::Keyframe>* stream) override;
  grpc::Status CloseSession(grpc::ServerContext* ctx, const loci::v1::CloseSessionRequest* req,
                            loci::v1::CloseSessionResponse* resp) override;

 private:
  grpc::Status Refuse() const;
  const std::string site_;
  const WriterAddress writer_;
};

// The refusal's text: "this is a read-only query server of site S; WHAT at the site's writer
// (ADDRESS)", or "(no writer holds the site now)".
std::string AtWriterMessage(const std::string& site, const std::string& what,
                            const std::string& writer_address);

}  // namespace loci::server
