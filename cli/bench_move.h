// `loci bench restart --move N [--chunk K]`: moves the last N keyframes of the built map as a
// pose-graph solution does (MoveInChunks, server/runtime/chunked_move.h) while a second thread
// maps new keyframes under the same lock, as loci-server's mapping worker does, and prints the
// move's time and how long that thread waited for the lock.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "common/status.h"
#include "server/map/mapper.h"
#include "server/storage/map_store.h"

namespace loci::cli {

// map_next: maps one more keyframe (called with the lock held, on the mapping thread).
Status TimeMoveWhileMapping(int64_t n, int64_t chunk_keyframes, server::Mapper& mapper,
                            server::MapStore& store, const std::string& fingerprint,
                            const std::function<void()>& map_next);

}  // namespace loci::cli
