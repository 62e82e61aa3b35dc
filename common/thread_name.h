// Names the calling thread, so that `top -H`, `perf report --sort comm`, gdb's `info threads` and
// /proc/PID/task/*/comm tell loci's threads apart. Linux keeps 15 characters; longer names are
// cut to them. Elsewhere it does nothing.
#pragma once

#include <string_view>

namespace loci {

void NameThisThread(std::string_view name);

}  // namespace loci
