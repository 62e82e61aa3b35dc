#include "common/task_pool.h"

#include <algorithm>
#include <thread>

#include "common/thread_name.h"

namespace loci {

TaskPool& TaskPool::Shared() {
  static TaskPool pool(std::max(2u, std::thread::hardware_concurrency()));
  return pool;
}

void TaskPool::NameThisPoolThread() {
  thread_local const bool named = (NameThisThread("loci-pool"), true);
  (void)named;
}

}  // namespace loci
