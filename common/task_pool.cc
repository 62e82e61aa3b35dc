#include "common/task_pool.h"

#include <algorithm>
#include <thread>

namespace loci {

TaskPool& TaskPool::Shared() {
  static TaskPool pool(std::max(2u, std::thread::hardware_concurrency()));
  return pool;
}

}  // namespace loci
