// Moving many mapped keyframes (a pose-graph solution), or mapping many stored ones (a robot's
// held keyframes when it is aligned), in chunks. The mapping worker takes the same lock for each
// keyframe it maps; moving 10k keyframes in one hold would stop it for seconds (about 0.5-1.5 ms
// per keyframe, measured), mapping 1000 held ones for about 10 s. Between two chunks the
// lock is free, so the worker waits for one chunk at most. What a reader sees between chunks is
// a map partly moved, or partly merged: moves go newest keyframe first, so what the robots see
// now is corrected first.
#pragma once

#include <cstddef>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>

#include "common/fifo_mutex.h"
#include "common/status.h"
#include "server/map/mapper.h"

namespace loci::server {

struct ChunkedMoveFigures {
  size_t moved = 0;             // keyframes moved or mapped (the chunks' sums)
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
    std::vector<Mapper::KeyframePoseUpdate> updates, size_t chunk_keyframes, FifoMutex& mu,
    const std::function<Status()>& still_valid,
    const std::function<StatusOr<size_t>(const std::vector<Mapper::KeyframePoseUpdate>&, bool last)>&
        move);

// A stored keyframe read back to be mapped: what Mapper::Integrate takes.
struct LoadedKeyframe {
  MapperKeyframe meta;
  KeyframeProducts products;
  // Its stored corrected pose, in the frame of the map holding it: the shared base frame once
  // its session is aligned (meta.T_base_kf then equals it), else its island's frame.
  std::optional<SE3d> T_kf_corrected;
};

// Maps the keyframes `ids` (increasing), oldest first, at most chunk_keyframes per hold of `mu`
// (0: all in one hold). `load(first_id, last_id)` reads the chunk's keyframes back without `mu`
// (the database, and products built from images where none are stored); `integrate` maps one
// with `mu` held and returns false when it skips it. A failed load stops the mapping with its
// error (the chunks before it stay mapped).
ChunkedMoveFigures MapInChunks(
    const std::vector<int64_t>& ids, size_t chunk_keyframes, FifoMutex& mu,
    const std::function<StatusOr<std::vector<LoadedKeyframe>>(int64_t first_id, int64_t last_id)>&
        load,
    const std::function<bool(const LoadedKeyframe&)>& integrate);

}  // namespace loci::server
