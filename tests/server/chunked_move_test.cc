// MoveInChunks: a pose-graph solution moves the map in chunks, newest keyframe first, each
// under the mapping lock, and stops where its check or a chunk fails.
#include "server/service/chunked_move.h"

#include <gtest/gtest.h>

#include <future>
#include <string>
#include <thread>

namespace loci::server {
namespace {

std::vector<Mapper::KeyframePoseUpdate> Updates(int64_t first_id, int64_t n) {
  std::vector<Mapper::KeyframePoseUpdate> out;
  for (int64_t id = first_id; id < first_id + n; ++id) {
    out.push_back({id, MakeSE3(Vec3d(0.01 * id, 0, 0), Quatd::Identity())});
  }
  return out;
}

// Whether another thread could take `mu` now.
bool FreeForAnotherThread(HandoffMutex& mu) {
  return std::async(std::launch::async, [&mu] {
           if (!mu.try_lock()) return false;
           mu.unlock();
           return true;
         }).get();
}

TEST(MoveInChunks, MovesNewestFirstOneChunkPerHoldOfTheLock) {
  HandoffMutex mu;
  std::vector<std::vector<int64_t>> chunks;
  std::vector<bool> lasts;
  int checks = 0;
  const ChunkedMoveFigures f = MoveInChunks(
      Updates(1, 10), 4, mu,
      [&] {
        ++checks;
        return absl::OkStatus();
      },
      [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) -> StatusOr<size_t> {
        EXPECT_FALSE(FreeForAnotherThread(mu)) << "a chunk moves with the lock held";
        lasts.push_back(last);
        chunks.emplace_back();
        for (const auto& u : chunk) chunks.back().push_back(u.keyframe_id);
        return chunk.size();
      });
  ASSERT_TRUE(f.status.ok()) << f.status;
  EXPECT_TRUE(FreeForAnotherThread(mu));
  const std::vector<std::vector<int64_t>> want = {{10, 9, 8, 7}, {6, 5, 4, 3}, {2, 1}};
  EXPECT_EQ(chunks, want);
  EXPECT_EQ(lasts, std::vector<bool>({false, false, true}));  // the OctoMap is rebuilt once
  EXPECT_EQ(checks, 3);
  EXPECT_EQ(f.moved, 10u);
  EXPECT_EQ(f.chunks, 3u);
  EXPECT_GE(f.total_ms, f.longest_hold_ms);
}

TEST(MoveInChunks, AThreadWaitingForTheLockGetsItBetweenTwoChunks) {
  HandoffMutex mu;
  std::vector<std::string> order;  // appended with mu held
  std::thread worker;
  const ChunkedMoveFigures f = MoveInChunks(
      Updates(1, 2), 1, mu, [] { return absl::OkStatus(); },
      [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool) -> StatusOr<size_t> {
        order.push_back("chunk " + std::to_string(chunk.front().keyframe_id));
        if (!worker.joinable()) {
          // The mapping worker asks for the lock while the first chunk holds it.
          worker = std::thread([&] {
            std::lock_guard<HandoffMutex> lock(mu);
            order.push_back("worker");
          });
          while (mu.waiters() == 0) std::this_thread::yield();
        }
        return chunk.size();
      });
  worker.join();
  ASSERT_TRUE(f.status.ok()) << f.status;
  const std::vector<std::string> want = {"chunk 2", "worker", "chunk 1"};
  EXPECT_EQ(order, want);
}

TEST(MoveInChunks, ZeroMeansOneHoldAndNothingToMoveTakesNone) {
  HandoffMutex mu;
  size_t calls = 0, largest = 0;
  auto move = [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool) -> StatusOr<size_t> {
    ++calls;
    largest = std::max(largest, chunk.size());
    return chunk.size();
  };
  auto ok = [] { return absl::OkStatus(); };
  ChunkedMoveFigures f = MoveInChunks(Updates(1, 300), 0, mu, ok, move);
  EXPECT_EQ(calls, 1u);
  EXPECT_EQ(largest, 300u);
  EXPECT_EQ(f.moved, 300u);
  f = MoveInChunks({}, 64, mu, ok, move);
  EXPECT_EQ(calls, 1u);
  EXPECT_EQ(f.chunks, 0u);
  EXPECT_EQ(f.total_ms, 0.0);
}

TEST(MoveInChunks, StopsWhereTheFrameChangedOrAChunkFailed) {
  HandoffMutex mu;
  size_t moved_calls = 0;
  auto move = [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool) -> StatusOr<size_t> {
    ++moved_calls;
    if (chunk.front().keyframe_id == 4) return absl::FailedPreconditionError("no products");
    return chunk.size();
  };
  // The check fails before the third chunk: two chunks stay moved, the rest is left.
  int checks = 0;
  ChunkedMoveFigures f = MoveInChunks(
      Updates(1, 10), 3, mu,
      [&] {
        return ++checks <= 2 ? absl::OkStatus() : absl::AbortedError("the map frame changed");
      },
      move);
  EXPECT_EQ(f.status.code(), absl::StatusCode::kAborted);
  EXPECT_EQ(f.moved, 6u);
  EXPECT_EQ(f.chunks, 2u);
  EXPECT_EQ(moved_calls, 2u);
  // A chunk that fails (its first keyframe has no products) ends the move there.
  moved_calls = 0;
  f = MoveInChunks(Updates(1, 10), 3, mu, [] { return absl::OkStatus(); }, move);
  EXPECT_EQ(f.status.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(f.moved, 6u);  // 10-8 and 7-5; 4-2 failed; 1 not tried
  EXPECT_EQ(moved_calls, 3u);
  EXPECT_TRUE(FreeForAnotherThread(mu));
}

}  // namespace
}  // namespace loci::server
