#include "common/thread_name.h"

#include <pthread.h>

#include <string>

namespace loci {

void NameThisThread(std::string_view name) {
#if defined(__linux__)
  constexpr size_t kMaxChars = 15;  // the kernel's TASK_COMM_LEN less the terminator
  const std::string cut(name.substr(0, kMaxChars));
  (void)pthread_setname_np(pthread_self(), cut.c_str());
#else
  (void)name;
#endif
}

}  // namespace loci
