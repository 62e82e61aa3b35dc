#include "server/runtime/chunked_move.h"

#include <algorithm>
#include <chrono>

#include "common/time.h"

namespace loci::server {

using Clock = std::chrono::steady_clock;

ChunkedMoveFigures MoveInChunks(
    std::vector<Mapper::KeyframePoseUpdate> updates, size_t chunk_keyframes, FifoMutex& mu,
    const std::function<Status()>& still_valid,
    const std::function<StatusOr<size_t>(const std::vector<Mapper::KeyframePoseUpdate>&, bool last)>&
        move) {
  std::stable_sort(updates.begin(), updates.end(),
                   [](const Mapper::KeyframePoseUpdate& a, const Mapper::KeyframePoseUpdate& b) {
                     return a.keyframe_id > b.keyframe_id;
                   });
  const size_t step = chunk_keyframes == 0 ? std::max<size_t>(updates.size(), 1) : chunk_keyframes;
  ChunkedMoveFigures f;
  const Clock::time_point start = Clock::now();
  for (size_t begin = 0; begin < updates.size(); begin += step) {
    const std::vector<Mapper::KeyframePoseUpdate> chunk(
        updates.begin() + static_cast<std::ptrdiff_t>(begin),
        updates.begin() + static_cast<std::ptrdiff_t>(std::min(begin + step, updates.size())));
    std::lock_guard<FifoMutex> lock(mu);
    const Clock::time_point held = Clock::now();
    f.status = still_valid();
    const bool last = begin + step >= updates.size();
    StatusOr<size_t> moved = f.status.ok() ? move(chunk, last) : StatusOr<size_t>(f.status);
    f.longest_hold_ms = std::max(f.longest_hold_ms, MsSince(held));
    if (!moved.ok()) {
      f.status = moved.status();
      break;
    }
    f.moved += *moved;
    ++f.chunks;
  }
  f.total_ms = updates.empty() ? 0.0 : MsSince(start);
  return f;
}

ChunkedMoveFigures MapInChunks(
    const std::vector<int64_t>& ids, size_t chunk_keyframes, FifoMutex& mu,
    const std::function<StatusOr<std::vector<LoadedKeyframe>>(int64_t first_id, int64_t last_id)>&
        load,
    const std::function<bool(const LoadedKeyframe&)>& integrate) {
  const size_t step = chunk_keyframes == 0 ? std::max<size_t>(ids.size(), 1) : chunk_keyframes;
  ChunkedMoveFigures f;
  const Clock::time_point start = Clock::now();
  for (size_t begin = 0; begin < ids.size(); begin += step) {
    const size_t end = std::min(begin + step, ids.size());
    StatusOr<std::vector<LoadedKeyframe>> loaded = load(ids[begin], ids[end - 1]);
    if (!loaded.ok()) {
      f.status = loaded.status();
      break;
    }
    std::lock_guard<FifoMutex> lock(mu);
    const Clock::time_point held = Clock::now();
    for (const LoadedKeyframe& kf : *loaded) f.moved += integrate(kf) ? 1 : 0;
    f.longest_hold_ms = std::max(f.longest_hold_ms, MsSince(held));
    ++f.chunks;
  }
  f.total_ms = ids.empty() ? 0.0 : MsSince(start);
  return f;
}

}  // namespace loci::server
