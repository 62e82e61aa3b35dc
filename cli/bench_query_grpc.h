// The gRPC half of `loci bench query`: Ask over loopback against an in-process loci server
// (MapServer + GrpcServer + QueryAdapter) whose map is the benchmark's synthetic snapshot.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/status.h"
#include "query/geometry.h"

namespace loci::cli {

struct GrpcBenchResult {
  double p50_ms = 0, p99_ms = 0, max_ms = 0;  // one client thread, wall clock per call
  double qps_1 = 0;                           // one client thread
  double qps_n = 0;                           // `threads` client threads
  size_t failures = 0;                        // transport errors or non-OK statuses
};

// Asks every question of `questions` once on one client thread, then all again on `threads`
// threads. The server answers from `objects` through the same adapter as loci-server.
StatusOr<GrpcBenchResult> RunGrpcAskBench(std::vector<MapObject> objects,
                                          const query::Viewpoint& view, int64_t now_ns,
                                          const std::vector<std::string>& questions, int threads);

}  // namespace loci::cli
