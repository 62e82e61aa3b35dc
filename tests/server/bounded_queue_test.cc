// BoundedQueue: order, capacity and back-pressure, TryPush, timeouts, Close semantics, and
// many producers with one consumer. Blocking is observed through the queue's own state and
// thread joins, never through sleeps.
#include "common/bounded_queue.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <set>
#include <thread>
#include <vector>

namespace loci::server {
namespace {

using namespace std::chrono_literals;

TEST(BoundedQueue, FifoWithinCapacity) {
  BoundedQueue<int> q(3);
  EXPECT_EQ(q.capacity(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(q.Push(i));
  EXPECT_EQ(q.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(q.Pop(), i);
  EXPECT_EQ(q.size(), 0u);
}

TEST(BoundedQueue, ZeroCapacityMeansOne) {
  BoundedQueue<int> q(0);
  EXPECT_EQ(q.capacity(), 1u);
  EXPECT_TRUE(q.TryPush(1));
  EXPECT_FALSE(q.TryPush(2));
}

TEST(BoundedQueue, TryPushRefusesWhenFullOrClosed) {
  BoundedQueue<int> q(1);
  EXPECT_TRUE(q.TryPush(1));
  EXPECT_FALSE(q.TryPush(2));
  EXPECT_EQ(q.Pop(), 1);
  q.Close();
  EXPECT_FALSE(q.TryPush(3));
  EXPECT_FALSE(q.Push(4));
}

TEST(BoundedQueue, PushBlocksWhileFullUntilAPop) {
  BoundedQueue<int> q(1);
  ASSERT_TRUE(q.Push(1));
  auto pushed = std::async(std::launch::async, [&] { return q.Push(2); });
  // The producer cannot finish while the queue is full.
  EXPECT_EQ(pushed.wait_for(50ms), std::future_status::timeout);
  EXPECT_EQ(q.size(), 1u);
  EXPECT_EQ(q.Pop(), 1);
  EXPECT_TRUE(pushed.get());  // unblocked by the Pop
  EXPECT_EQ(q.Pop(), 2);
}

TEST(BoundedQueue, CloseWakesABlockedProducerAndDropsItsItem) {
  BoundedQueue<int> q(1);
  ASSERT_TRUE(q.Push(1));
  auto pushed = std::async(std::launch::async, [&] { return q.Push(2); });
  EXPECT_EQ(pushed.wait_for(50ms), std::future_status::timeout);
  q.Close();
  EXPECT_FALSE(pushed.get());
  EXPECT_EQ(q.Pop(), 1);  // what was queued before Close still drains
  EXPECT_EQ(q.Pop(), std::nullopt);
}

TEST(BoundedQueue, CloseWakesABlockedConsumer) {
  BoundedQueue<int> q(2);
  auto popped = std::async(std::launch::async, [&] { return q.Pop(); });
  EXPECT_EQ(popped.wait_for(50ms), std::future_status::timeout);
  q.Close();
  EXPECT_EQ(popped.get(), std::nullopt);
}

TEST(BoundedQueue, PopForTimesOutEmptyAndReturnsAnItemAtOnce) {
  BoundedQueue<int> q(2);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(q.PopFor(30ms), std::nullopt);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 30ms);
  ASSERT_TRUE(q.Push(7));
  EXPECT_EQ(q.PopFor(10s), 7);
}

TEST(BoundedQueue, ManyProducersOneConsumerLoseNothing) {
  constexpr int kProducers = 4, kEach = 2000;
  BoundedQueue<int> q(8);
  std::vector<std::thread> producers;
  for (int p = 0; p < kProducers; ++p) {
    producers.emplace_back([&q, p] {
      for (int i = 0; i < kEach; ++i) ASSERT_TRUE(q.Push(p * kEach + i));
    });
  }
  std::set<int> seen;
  std::vector<int> last(kProducers, -1);
  for (int n = 0; n < kProducers * kEach; ++n) {
    const std::optional<int> v = q.Pop();
    ASSERT_TRUE(v.has_value());
    EXPECT_LE(q.size(), q.capacity());
    const int producer = *v / kEach;
    EXPECT_GT(*v, last[producer]);  // each producer's items stay in order
    last[producer] = *v;
    seen.insert(*v);
  }
  for (std::thread& t : producers) t.join();
  EXPECT_EQ(seen.size(), static_cast<size_t>(kProducers * kEach));
  EXPECT_EQ(q.size(), 0u);
}

}  // namespace
}  // namespace loci::server
