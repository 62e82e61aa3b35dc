#include "common/time.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

#include <charconv>

namespace loci {
namespace {

bool ParseDigits(std::string_view s, int64_t* out) {
  if (s.empty()) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

Status NotAStamp(std::string_view text) {
  return absl::InvalidArgumentError(
      absl::StrCat("not a time stamp in seconds: '", std::string(text), "'"));
}

}  // namespace

StatusOr<int64_t> ParseSecondsToNs(std::string_view text) {
  bool negative = false;
  if (!text.empty() && text.front() == '-') {
    negative = true;
    text.remove_prefix(1);
  }
  const size_t dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  std::string_view frac = dot == std::string_view::npos ? std::string_view() : text.substr(dot + 1);
  int64_t s = 0;
  if (!ParseDigits(whole, &s)) return NotAStamp(text);
  int64_t frac_ns = 0;
  if (frac.size() > 9) frac = frac.substr(0, 9);
  if (!frac.empty()) {
    int64_t f = 0;
    if (!ParseDigits(frac, &f)) return NotAStamp(text);
    frac_ns = f;
    for (size_t i = frac.size(); i < 9; ++i) frac_ns *= 10;
  }
  const int64_t ns = s * kNsPerSecond + frac_ns;
  return negative ? -ns : ns;
}

std::string FormatNsAsSeconds(int64_t t_ns) {
  const int64_t us = (t_ns + (t_ns >= 0 ? 500 : -500)) / 1000;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s%lld.%06lld", us < 0 ? "-" : "",
                static_cast<long long>(std::llabs(us) / 1'000'000),
                static_cast<long long>(std::llabs(us) % 1'000'000));
  return buf;
}

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

}  // namespace loci
