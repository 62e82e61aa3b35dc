// Time stamps: int64 nanoseconds everywhere (t_ns). TUM files use decimal seconds.
#pragma once

#include <cmath>
#include <cstdint>
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

}  // namespace loci
