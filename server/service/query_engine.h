// Seam for the natural-language query engine (query issue): the Query service's Ask rpc calls
// the installed engine; without one it answers with a FAILED_PRECONDITION status message.
#pragma once

#include "loci/v1/query.pb.h"

namespace loci::server {

class MapServer;

class QueryEngine {
 public:
  virtual ~QueryEngine() = default;
  // Answers one question from the map (MapServer::mapper(): Snapshot(), UpDirection(),
  // LatestPoses()). Problems go into response.status, never into a failed call.
  virtual loci::v1::AskResponse Ask(const loci::v1::AskRequest& request,
                                    const MapServer& server) = 0;
};

}  // namespace loci::server
