// Moving many mapped keyframes (a pose-graph solution) in chunks. The mapping worker takes the
// same lock for each keyframe it maps; moving 10k keyframes in one hold would stop it for
// seconds (about 0.5-1.5 ms per keyframe, docs/results.md). Between two chunks the lock is free,
// so the worker waits for one chunk at most. What a reader sees between chunks is a map partly
// moved: the chunks go newest keyframe first, so what the robots see now is corrected first.
#pragma once

#include <cstddef>
#include <functional>
#include <mutex>
#include <vector>

#include "common/handoff_mutex.h"
#include "common/status.h"
#include "server/map/mapper.h"

namespace loci::server {

struct ChunkedMoveFigures {
  size_t moved = 0;             // keyframes moved (the chunks' sums)
  size_t chunks = 0;            // chunks applied
  double total_ms = 0;          // wall time from the first chunk's lock to the last's release
  double longest_hold_ms = 0;   // the longest single hold of the lock
  Status status;                // what stopped the move early (the chunks before it stay moved)
};

// Moves `updates` newest keyframe (highest id) first, at most chunk_keyframes per hold of `mu`
// (0: all in one hold); between two chunks a thread waiting for `mu` gets it first. `still_valid`, called with `mu` held before each chunk, stops the move
// with its error (the rest stays where it is: the next solve moves it); `move` moves one chunk
// with `mu` held (`last`: the last chunk, after which the OctoMap is rebuilt once) and returns
// how many keyframes it moved, or the error that stops the move.
ChunkedMoveFigures MoveInChunks(
    std::vector<Mapper::KeyframePoseUpdate> updates, size_t chunk_keyframes, HandoffMutex& mu,
    const std::function<Status()>& still_valid,
    const std::function<StatusOr<size_t>(const std::vector<Mapper::KeyframePoseUpdate>&, bool last)>&
        move);

}  // namespace loci::server
