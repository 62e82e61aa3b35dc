// A fixed pool of worker threads for short CPU work that runs beside the caller's own (the dense
// cloud of a keyframe's products, the cloud half of a keyframe move). Threads are made once per
// process, not per task. Built on Boost.Asio's thread_pool, whose hand-off goes through pthread
// mutexes and condition variables, so ThreadSanitizer sees it (TBB's does not).
#pragma once

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>
#include <future>
#include <memory>
#include <type_traits>
#include <utility>

namespace loci {

class TaskPool {
 public:
  explicit TaskPool(size_t threads) : pool_(threads) {}
  ~TaskPool() { pool_.join(); }
  TaskPool(const TaskPool&) = delete;
  TaskPool& operator=(const TaskPool&) = delete;

  // The process-wide pool: as many threads as cores, at least 2.
  static TaskPool& Shared();

  // Runs f() on a pool thread. The caller must not wait on the future from inside a pool task
  // (the pool is small; a task waiting on another could wait for a free thread forever).
  template <class F>
  std::future<std::invoke_result_t<F>> Submit(F f) {
    auto task = std::make_shared<std::packaged_task<std::invoke_result_t<F>()>>(std::move(f));
    std::future<std::invoke_result_t<F>> result = task->get_future();
    boost::asio::post(pool_, [task] {
      NameThisPoolThread();
      (*task)();
    });
    return result;
  }

 private:
  // Names the pool thread running it "loci-pool", once per thread (common/thread_name.h).
  static void NameThisPoolThread();

  boost::asio::thread_pool pool_;
};

}  // namespace loci
