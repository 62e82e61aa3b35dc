// Keyframes mapped while a pose-graph solve ran. The solve works on a snapshot of the mapped
// keyframes and runs without the mapping lock, so the mapping worker goes on; the keyframes it
// maps meanwhile are not in the solution. Each follows the correction of its session's newest
// solved keyframe (they share that session's placement), so the session stays rigid from its
// newest solved keyframe on.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "server/map/mapper.h"

namespace loci::server {

// `solved`: the snapshot the graph saw (id order), `moved`: the solution's poses of those that
// moved, `now`: every mapped keyframe's pose at the time the solution is applied (id order);
// `session_of`: a keyframe's session row (nullopt: unknown, left alone). Returns, for each
// keyframe of `now` that is not in `solved` and whose session's newest solved keyframe moved,
// T_new_last T_old_last^-1 T_now.
std::vector<Mapper::KeyframePoseUpdate> LateKeyframeUpdates(
    const std::vector<Mapper::KeyframePoseUpdate>& solved,
    const std::vector<Mapper::KeyframePoseUpdate>& moved,
    const std::vector<Mapper::KeyframePoseUpdate>& now,
    const std::function<std::optional<int64_t>(int64_t)>& session_of);

}  // namespace loci::server
