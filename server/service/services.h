// gRPC services of the map server: Mapping (sessions, keyframe stream) and Query (structured
// queries, exports, object events). Thin wrappers around MapServer.
#pragma once

#include <memory>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/map_server.h"
#include "server/service/query_engine.h"

namespace loci::server {

class MappingService final : public loci::v1::Mapping::Service {
 public:
  explicit MappingService(MapServer* server) : server_(server) {}
  grpc::Status OpenSession(grpc::ServerContext* ctx, const loci::v1::OpenSessionRequest* req,
                           loci::v1::OpenSessionResponse* resp) override;
  grpc::Status StreamKeyframes(
      grpc::ServerContext* ctx,
      grpc::ServerReaderWriter<loci::v1::KeyframeAck, loci::v1::Keyframe>* stream) override;
  grpc::Status CloseSession(grpc::ServerContext* ctx, const loci::v1::CloseSessionRequest* req,
                            loci::v1::CloseSessionResponse* resp) override;

 private:
  MapServer* server_;
};

class QueryService final : public loci::v1::Query::Service {
 public:
  // `engine` answers Ask (null: Ask is UNIMPLEMENTED). Both are fixed before serving starts.
  QueryService(MapServer* server, std::shared_ptr<QueryEngine> engine)
      : server_(server), engine_(std::move(engine)) {}

  grpc::Status Ask(grpc::ServerContext* ctx, const loci::v1::AskRequest* req,
                   loci::v1::AskResponse* resp) override;
  grpc::Status FindObjects(grpc::ServerContext* ctx, const loci::v1::FindObjectsRequest* req,
                           loci::v1::FindObjectsResponse* resp) override;
  grpc::Status GetObject(grpc::ServerContext* ctx, const loci::v1::GetObjectRequest* req,
                         loci::v1::GetObjectResponse* resp) override;
  grpc::Status GetCloud(grpc::ServerContext* ctx, const loci::v1::GetCloudRequest* req,
                        loci::v1::GetCloudResponse* resp) override;
  grpc::Status GetOctomap(grpc::ServerContext* ctx, const loci::v1::GetOctomapRequest* req,
                          loci::v1::GetOctomapResponse* resp) override;
  grpc::Status WatchObjects(grpc::ServerContext* ctx, const loci::v1::WatchObjectsRequest* req,
                            grpc::ServerWriter<loci::v1::ObjectEvent>* writer) override;
  grpc::Status GetStats(grpc::ServerContext* ctx, const loci::v1::GetStatsRequest* req,
                        loci::v1::GetStatsResponse* resp) override;
  grpc::Status GetTrajectories(grpc::ServerContext* ctx,
                               const loci::v1::GetTrajectoriesRequest* req,
                               loci::v1::GetTrajectoriesResponse* resp) override;

 private:
  MapServer* const server_;
  const std::shared_ptr<QueryEngine> engine_;
};

// absl status <-> grpc status (same code numbering).
grpc::Status ToGrpc(const Status& s);
Status FromGrpc(const grpc::Status& s);

}  // namespace loci::server
