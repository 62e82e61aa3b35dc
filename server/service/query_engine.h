// Seam for the natural-language query engine behind the Query service's Ask rpc
// (server/service/query_adapter.h implements it over query/). It is given to GrpcServer::Start
// and fixed for the server's life; without one, Ask fails with UNIMPLEMENTED.
#pragma once

#include "common/status.h"
#include "loci/v1/query.pb.h"

namespace loci::server {

class MapServer;

class QueryEngine {
 public:
  virtual ~QueryEngine() = default;
  // Answers one question from the map (MapServer::mapper(): Snapshot(), UpDirection(),
  // LatestPoses()). A question it cannot take (unknown words, too long, not UTF-8) is an
  // error status (INVALID_ARGUMENT), which the Ask rpc returns as its gRPC status.
  virtual StatusOr<loci::v1::AskResponse> Ask(const loci::v1::AskRequest& request,
                                              const MapServer& server) = 0;
};

}  // namespace loci::server
