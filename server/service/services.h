// gRPC services of the map server: Mapping (sessions, keyframe stream) and Query (structured
// queries, exports, object events). Thin wrappers around MapServer.
#pragma once

#include <memory>

#include <grpcpp/support/byte_buffer.h>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/auth.h"
#include "server/service/query_api.h"
#include "server/runtime/map_server.h"
#include "server/service/query_engine.h"

namespace loci::server {

// The caller of a gRPC call, from its `authorization` metadata.
StatusOr<Principal> Caller(const Authorizer& auth, const grpc::ServerContext& ctx);
// OK when the call's caller may read the map (auth.h).
grpc::Status AllowRead(const Authorizer& auth, const grpc::ServerContext& ctx);

// FindObjects on any list of objects: the request's check (INVALID_ARGUMENT), then the objects
// it selects, in the list's order, up to its limit.
grpc::Status CheckFindObjects(const loci::v1::FindObjectsRequest& req);
void SelectObjects(const loci::v1::FindObjectsRequest& req, const std::vector<MapObject>& objects,
                   loci::v1::FindObjectsResponse* resp);

class MappingService final : public loci::v1::Mapping::Service {
 public:
  // `auth` outlives the service; every call is checked against it (auth.h).
  MappingService(MapServer* server, const Authorizer* auth);
  grpc::Status OpenSession(grpc::ServerContext* ctx, const loci::v1::OpenSessionRequest* req,
                           loci::v1::OpenSessionResponse* resp) override;
  // StreamKeyframes reads raw message bytes and parses them itself, so that a message that is
  // not a Keyframe ends the stream with INVALID_ARGUMENT; the typed handler cannot tell such a
  // message from the client's half-close.
  grpc::Status StreamKeyframeBytes(
      grpc::ServerContext* ctx,
      grpc::ServerReaderWriter<loci::v1::KeyframeAck, grpc::ByteBuffer>* stream);
  grpc::Status CloseSession(grpc::ServerContext* ctx, const loci::v1::CloseSessionRequest* req,
                            loci::v1::CloseSessionResponse* resp) override;

 private:
  MapServer* server_;
  const Authorizer* auth_;
};

class QueryService final : public loci::v1::Query::Service, public QueryApi {
 public:
  // `engine` answers Ask (null: Ask is UNIMPLEMENTED). Both are fixed before serving starts.
  // Every gRPC call needs a caller that may read (auth.h); the HTTP API authenticates its own
  // requests and calls the methods without a context.
  QueryService(MapServer* server, std::shared_ptr<QueryEngine> engine, const Authorizer* auth)
      : server_(server), engine_(std::move(engine)), auth_(auth) {}

  grpc::Status Ask(const loci::v1::AskRequest& req, loci::v1::AskResponse* resp) override;
  grpc::Status FindObjects(const loci::v1::FindObjectsRequest& req,
                           loci::v1::FindObjectsResponse* resp) override;
  grpc::Status GetObject(const loci::v1::GetObjectRequest& req,
                         loci::v1::GetObjectResponse* resp) override;
  grpc::Status GetStats(loci::v1::GetStatsResponse* resp) override;
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
  grpc::Status AllowRead(const grpc::ServerContext& ctx) const;
  // GetStats' sessions and alignment figures.
  grpc::Status FillAlignment(const std::vector<SessionRecord>& sessions,
                             loci::v1::GetStatsResponse* resp);
  static void FillPoseGraph(const std::optional<LoopStats>& st, loci::v1::PoseGraphStats* out);
  // An island's own pose-graph figures (SessionAlignment.island_*).
  static void FillIslandGraph(const std::optional<LoopStats>& st, int64_t island_row,
                              loci::v1::SessionAlignment* out);
  // The shared map ("") or the map island named `island`; NOT_FOUND for an unknown island.
  StatusOr<std::shared_ptr<const Mapper>> MapNamed(const std::string& island) const;

  MapServer* const server_;
  const std::shared_ptr<QueryEngine> engine_;
  const Authorizer* const auth_;
};

// WatchObjects on `api`'s events: subscribes, sends the initial metadata (the watch is
// registered: every later event comes), then writes each event until the call is cancelled, the
// client is gone or the event queue closes (the server shuts down).
grpc::Status StreamObjectEvents(QueryApi& api, grpc::ServerContext* ctx,
                                grpc::ServerWriter<loci::v1::ObjectEvent>* writer);

// An object event as WatchObjects sends it, stamped t_ns (server wall time).
void ToProto(const ObjectEventOut& in, int64_t t_ns, loci::v1::ObjectEvent* out);

// absl status <-> grpc status (same code numbering).
grpc::Status ToGrpc(const Status& s);
Status FromGrpc(const grpc::Status& s);

}  // namespace loci::server
