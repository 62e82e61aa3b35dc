// MoveInChunks: a pose-graph solution moves the map in chunks, newest keyframe first, each
// under the mapping lock, and stops where its check or a chunk fails. MapInChunks: an aligned
// robot's held keyframes are read back without the lock and mapped in chunks, oldest first.
#include "server/runtime/chunked_move.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <future>
#include <mutex>
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
bool FreeForAnotherThread(FifoMutex& mu) {
  return std::async(std::launch::async, [&mu] {
           if (!mu.try_lock()) return false;
           mu.unlock();
           return true;
         }).get();
}

TEST(MoveInChunks, MovesNewestFirstOneChunkPerHoldOfTheLock) {
  FifoMutex mu;
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
  FifoMutex mu;
  std::vector<std::string> order;  // appended with mu held
  std::thread worker;
  const ChunkedMoveFigures f = MoveInChunks(
      Updates(1, 2), 1, mu, [] { return absl::OkStatus(); },
      [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool) -> StatusOr<size_t> {
        order.push_back("chunk " + std::to_string(chunk.front().keyframe_id));
        if (!worker.joinable()) {
          // The mapping worker asks for the lock while the first chunk holds it.
          worker = std::thread([&] {
            std::lock_guard<FifoMutex> lock(mu);
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
  FifoMutex mu;
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
  FifoMutex mu;
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

// MapInChunks' load: the chunk's ids as keyframes (no products), read without `mu`.
std::function<StatusOr<std::vector<LoadedKeyframe>>(int64_t, int64_t)> LoadIds(
    FifoMutex& mu, const std::vector<int64_t>& ids, std::vector<std::string>* order) {
  return [&mu, ids, order](int64_t first, int64_t last) -> StatusOr<std::vector<LoadedKeyframe>> {
    EXPECT_TRUE(FreeForAnotherThread(mu)) << "keyframes are read back without the lock";
    order->push_back("load " + std::to_string(first) + "-" + std::to_string(last));
    std::vector<LoadedKeyframe> out;
    for (int64_t id : ids) {
      if (id < first || id > last) continue;
      out.emplace_back();
      out.back().meta.keyframe_id = id;
    }
    return out;
  };
}

TEST(MapInChunks, MapsOldestFirstReadingEachChunkWithoutTheLock) {
  FifoMutex mu;
  const std::vector<int64_t> ids = {3, 4, 7, 9, 12};  // other robots' keyframes in between
  std::vector<std::string> order;
  const ChunkedMoveFigures f =
      MapInChunks(ids, 2, mu, LoadIds(mu, ids, &order), [&](const LoadedKeyframe& kf) {
        EXPECT_FALSE(FreeForAnotherThread(mu)) << "keyframes are mapped with the lock held";
        order.push_back(std::to_string(kf.meta.keyframe_id));
        return kf.meta.keyframe_id != 9;  // already in the map: skipped
      });
  ASSERT_TRUE(f.status.ok()) << f.status;
  const std::vector<std::string> want = {"load 3-4", "3", "4", "load 7-9", "7", "9",
                                         "load 12-12", "12"};
  EXPECT_EQ(order, want);
  EXPECT_EQ(f.moved, 4u);
  EXPECT_EQ(f.chunks, 3u);
  EXPECT_TRUE(FreeForAnotherThread(mu));
}

TEST(MapInChunks, AThreadWaitingForTheLockGetsItBetweenTwoChunks) {
  FifoMutex mu;
  std::mutex order_mu;  // the reads run without `mu`, beside the worker
  std::vector<std::string> order;
  auto note = [&](const std::string& what) {
    std::lock_guard<std::mutex> lock(order_mu);
    order.push_back(what);
  };
  std::thread worker;
  const ChunkedMoveFigures f = MapInChunks(
      {1, 2}, 1, mu,
      [&](int64_t first, int64_t) -> StatusOr<std::vector<LoadedKeyframe>> {
        note("load " + std::to_string(first));
        std::vector<LoadedKeyframe> out(1);
        out[0].meta.keyframe_id = first;
        return out;
      },
      [&](const LoadedKeyframe& kf) {
        note("map " + std::to_string(kf.meta.keyframe_id));
        if (!worker.joinable()) {
          worker = std::thread([&] {
            std::lock_guard<FifoMutex> lock(mu);
            note("worker");
          });
          while (mu.waiters() == 0) std::this_thread::yield();
        }
        return true;
      });
  worker.join();
  ASSERT_TRUE(f.status.ok()) << f.status;
  // The worker, waiting while the first chunk was mapped, maps before the second chunk (whose
  // read may come before or after the worker's turn).
  auto at = [&](const std::string& what) {
    return std::find(order.begin(), order.end(), what) - order.begin();
  };
  ASSERT_EQ(order.size(), 5u);
  EXPECT_LT(at("map 1"), at("worker"));
  EXPECT_LT(at("worker"), at("map 2"));
  EXPECT_LT(at("load 2"), at("map 2"));
}

TEST(MapInChunks, AFailedReadStopsTheMappingAndZeroMeansOneHold) {
  FifoMutex mu;
  std::vector<int64_t> ids;
  for (int64_t id = 1; id <= 10; ++id) ids.push_back(id);
  std::vector<std::string> order;
  auto load = LoadIds(mu, ids, &order);
  size_t mapped = 0;
  auto integrate = [&](const LoadedKeyframe&) { return ++mapped > 0; };
  ChunkedMoveFigures f = MapInChunks(
      ids, 4, mu,
      [&](int64_t first, int64_t last) -> StatusOr<std::vector<LoadedKeyframe>> {
        if (first == 5) return absl::DataLossError("database gone");
        return load(first, last);
      },
      integrate);
  EXPECT_EQ(f.status.code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(f.moved, 4u);  // 1-4 stay mapped
  EXPECT_EQ(f.chunks, 1u);
  order.clear();
  f = MapInChunks(ids, 0, mu, load, integrate);
  EXPECT_EQ(order, std::vector<std::string>({"load 1-10"}));
  EXPECT_EQ(f.chunks, 1u);
  EXPECT_EQ(f.moved, 10u);
  f = MapInChunks({}, 8, mu, load, integrate);
  EXPECT_EQ(f.chunks, 0u);
  EXPECT_EQ(f.total_ms, 0.0);
}

}  // namespace
}  // namespace loci::server
