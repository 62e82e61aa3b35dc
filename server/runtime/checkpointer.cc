#include "server/runtime/checkpointer.h"

#include <spdlog/spdlog.h>

#include <limits>

#include "common/malloc_tuning.h"
#include "common/time.h"

namespace loci::server {

CheckpointRecord MakeCheckpoint(const Mapper& mapper) {
  CheckpointRecord record;
  record.last_keyframe_id = mapper.last_keyframe_id();
  record.data = mapper.SaveCheckpoint();
  return record;
}

Status Checkpointer::Write() {
  std::lock_guard<std::mutex> lock(write_mu_);
  const auto t0 = std::chrono::steady_clock::now();
  CheckpointRecord record = MakeCheckpoint(*mapper_);
  if (record.data.empty()) return absl::OkStatus();  // the map frame is not settled yet
  LOCI_RETURN_IF_ERROR(store_->PutCheckpoint(record));
  ++written_;
  spdlog::info("checkpoint at keyframe {}: {:.1f} MB in {:.2f} s", record.last_keyframe_id,
               static_cast<double>(record.data.size()) / 1e6,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  // Free the checkpoint's bytes, then give back every page freed since the last solve or
  // checkpoint (a map without loop closure has no solves to trim after).
  record = {};
  ReleaseFreeHeapPages();
  return ApplyRetention();
}

Status Checkpointer::ApplyRetention() {
  if (options_.raw_keep_days < 0 && options_.raw_keep_last < 0) return absl::OkStatus();
  const int64_t before_ns = options_.raw_keep_days < 0
                                ? std::numeric_limits<int64_t>::min()
                                : NowNs() - SecondsToNs(options_.raw_keep_days * 86'400.0);
  LOCI_ASSIGN_OR_RETURN(const uint64_t dropped,
                        store_->DropRawImages(before_ns, options_.raw_keep_last));
  if (dropped > 0) spdlog::info("retention: dropped the images of {} keyframes", dropped);
  return absl::OkStatus();
}

void Checkpointer::MaybeWrite(bool shared_map_changed) {
  if (shared_map_changed) ++since_;
  if (merging_) return;                   // WriteAfterMerge writes when they are all in
  if (since_ == 0 && !due_) return;       // the last checkpoint holds the map
  const auto now = std::chrono::steady_clock::now();
  if (!due_ && since_ < static_cast<uint64_t>(options_.checkpoint_keyframes) &&
      now - last_ < std::chrono::duration<double>(options_.checkpoint_interval_s)) {
    return;
  }
  // A checkpoint holds the OctoMap as rebuilt after the last pose update: the worker does not
  // wait for that rebuild with the map lock held (about 9 ms per keyframe: 11 s at 1250, every
  // robot's stream stopped meanwhile). It checkpoints on its first keyframe after.
  if (mapper_->OctomapRebuilding()) {
    due_ = true;
    return;
  }
  WriteNow(now);
}

void Checkpointer::WriteAfterMerge(uint64_t merged) {
  merging_ = false;
  since_ += merged;
  if (mapper_->OctomapRebuilding()) {
    due_ = true;  // MaybeWrite takes it after the rebuild
    return;
  }
  WriteNow(std::chrono::steady_clock::now());
}

void Checkpointer::WriteNow(std::chrono::steady_clock::time_point now) {
  due_ = false;
  // A failed one is not retried before the next is due: the store's error would repeat on
  // every keyframe.
  if (Status s = Write(); !s.ok()) spdlog::warn("checkpoint: {}", s.ToString());
  since_ = 0;
  last_ = now;
}

}  // namespace loci::server
