// Time stamps: int64 nanoseconds everywhere (t_ns). TUM files use decimal seconds.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <string_view>

#include "common/status.h"

namespace loci {

constexpr int64_t kNsPerSecond = 1'000'000'000;

// Parses "1305031229.528784" exactly (no double rounding) to nanoseconds.
StatusOr<int64_t> ParseSecondsToNs(std::string_view text);
// Formats nanoseconds as seconds with 6 decimals, as TUM files do ("1305031229.528784").
std::string FormatNsAsSeconds(int64_t t_ns);
inline double NsToSeconds(int64_t t_ns) { return static_cast<double>(t_ns) * 1e-9; }
inline int64_t SecondsToNs(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }
// Wall-clock now, ns since the Unix epoch.
int64_t NowNs();
// Wall milliseconds since `start` (steady clock): a stage's duration as a caller waits for it.
inline double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}
// CPU time of the calling thread in milliseconds (CLOCK_THREAD_CPUTIME_ID): a stage's own cost,
// unaffected by other load on the machine.
double ThreadCpuMs();

// The element of `sorted` (ascending t_ns member) whose stamp is nearest t_ns, if within
// max_dt_ns; nullptr otherwise. Of two equally near elements the later one wins.
template <typename T>
const T* NearestByTime(std::span<const T> sorted, int64_t t_ns, int64_t max_dt_ns) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t_ns,
                                   [](const T& e, int64_t t) { return e.t_ns < t; });
  const T* best = nullptr;
  if (it != sorted.end()) best = &*it;
  if (it != sorted.begin()) {
    const T* prev = &*(it - 1);
    if (!best || t_ns - prev->t_ns < best->t_ns - t_ns) best = prev;
  }
  return best && std::llabs(best->t_ns - t_ns) <= max_dt_ns ? best : nullptr;
}

}  // namespace loci
