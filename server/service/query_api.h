// The Query service's calls without a gRPC context, for the transports that authenticate their
// own requests (the HTTP API, its event stream). A mapping server's QueryService and a read-only
// query server's ReadOnlyQueryService both answer them, so HTTP and gRPC answers agree on both.
#pragma once

#include <memory>

#include <grpcpp/support/status.h>

#include "common/status.h"
#include "loci/v1/query.pb.h"
#include "server/runtime/event_fanout.h"

namespace loci::server {

class QueryApi {
 public:
  virtual ~QueryApi() = default;

  virtual grpc::Status Ask(const loci::v1::AskRequest& req, loci::v1::AskResponse* resp) = 0;
  virtual grpc::Status FindObjects(const loci::v1::FindObjectsRequest& req,
                                   loci::v1::FindObjectsResponse* resp) = 0;
  virtual grpc::Status GetObject(const loci::v1::GetObjectRequest& req,
                                 loci::v1::GetObjectResponse* resp) = 0;
  virtual grpc::Status GetStats(loci::v1::GetStatsResponse* resp) = 0;
  virtual grpc::Status GetCloud(const loci::v1::GetCloudRequest& req,
                                loci::v1::GetCloudResponse* resp) = 0;
  virtual grpc::Status GetTrajectories(const loci::v1::GetTrajectoriesRequest& req,
                                       loci::v1::GetTrajectoriesResponse* resp) = 0;
  // The object events WatchObjects streams: every change after the call lands in `queue`
  // (a full queue loses events, it never blocks the map); RESOURCE_EXHAUSTED beyond
  // server.max_watchers subscribers, UNAVAILABLE before the map is loaded.
  virtual Status SubscribeObjects(std::shared_ptr<ObjectEventQueue> queue) = 0;
  virtual void UnsubscribeObjects(const std::shared_ptr<ObjectEventQueue>& queue) = 0;
};

}  // namespace loci::server
