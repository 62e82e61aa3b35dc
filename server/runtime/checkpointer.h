// Checkpoints of the shared map (server/map: Mapper::SaveCheckpoint) into the store, and the
// raw-image retention after each. A checkpoint is due after checkpoint_keyframes keyframes
// mapped or moved, or checkpoint_interval_s, since the last; not while an aligned robot's held
// keyframes enter the map (one taken between two chunks would hold a later keyframe id than held
// keyframes it lacks, which a restart would then not map), nor while the OctoMap rebuilds after
// a pose update (the worker would wait for it with the map lock held): it is taken after.
//
// Write runs on any thread between two keyframes; the other calls are made with the map lock
// held, which guards the counters.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>

#include "common/status.h"
#include "server/map/mapper.h"
#include "server/runtime/server_options.h"
#include "server/storage/map_store.h"

namespace loci::server {

// A checkpoint of `mapper`'s map; empty data while the map frame is not settled.
CheckpointRecord MakeCheckpoint(const Mapper& mapper);

class Checkpointer {
 public:
  // `mapper`: the server's (a load may replace the Mapper it holds).
  Checkpointer(const ServerOptions& options, const std::unique_ptr<Mapper>& mapper,
               MapStore* store)
      : options_(options), mapper_(mapper), store_(store) {}

  // Writes a checkpoint now, covering every keyframe mapped so far; nothing while the map frame
  // is not settled. Then applies the retention.
  Status Write();

  // Map lock held: keyframes of the shared map mapped or moved.
  void Changed(uint64_t keyframes) { since_ += keyframes; }
  // Map lock held: held keyframes are entering the map (true) or all in (false).
  void HoldForMerge(bool merging) { merging_ = merging; }
  // Map lock held, by the worker after each keyframe: writes one when due.
  void MaybeWrite(bool shared_map_changed);
  // Map lock held, once held keyframes (below the last checkpoint's id) are all in: writes one
  // now unless the OctoMap rebuilds (then on the worker's first keyframe after).
  void WriteAfterMerge(uint64_t merged);
  // Whether the map changed since the last checkpoint (map lock held, or no mapping thread).
  bool dirty() const { return since_ > 0; }
  uint64_t written() const { return written_; }

 private:
  // The checkpoint and its bookkeeping, map lock held.
  void WriteNow(std::chrono::steady_clock::time_point now);
  // Drops raw images as server.raw_keep_days / raw_keep_last say.
  Status ApplyRetention();

  const ServerOptions& options_;
  const std::unique_ptr<Mapper>& mapper_;
  MapStore* store_;
  std::mutex write_mu_;  // one checkpoint at a time
  std::atomic<uint64_t> written_{0};
  uint64_t since_ = 0;   // keyframes mapped or moved since the last checkpoint
  bool merging_ = false;
  bool due_ = false;     // fell due while the OctoMap rebuilt
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace loci::server
