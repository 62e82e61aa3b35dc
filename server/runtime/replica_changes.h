// The object events a read-only query server streams: what changed between two publications of
// the writer's map, by object id. A new id is CREATED; a known one whose state differs is
// UPDATED, or MOVED when its history gained a move; one found gone (in the removed list now) is
// REMOVED with the history's evidence; one no longer published at all was absorbed by a merge
// and is REMOVED with its last state (the survivor's UPDATED comes in the same batch: the
// publication does not say which object absorbed it, so no MERGED is sent).
#pragma once

#include <vector>

#include "server/map/mapper.h"
#include "server/runtime/replica_map.h"

namespace loci::server {

// The changes from `before` to `after`: created, updated and moved objects by id, then removed.
std::vector<ObjectEventOut> ChangesBetween(const ReplicaSnapshot& before,
                                           const ReplicaSnapshot& after);

}  // namespace loci::server
