// Names the calling thread, so that `top -H`, `perf report --sort comm`, gdb's `info threads` and
// /proc/PID/task/*/comm tell loci's threads apart. Linux keeps 15 characters; longer names are
// cut to them. Elsewhere it does nothing.
#pragma once

#include <string>
#include <string_view>
#include <thread>
#include <utility>

namespace loci {

void NameThisThread(std::string_view name);

// A thread that names itself `name` and then runs f().
template <class F>
std::thread NamedThread(std::string name, F f) {
  return std::thread([name = std::move(name), f = std::move(f)]() mutable {
    NameThisThread(name);
    f();
  });
}

}  // namespace loci
