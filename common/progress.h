// Progress on stderr for long loops: a bar redrawn in place ("\r") on a terminal; otherwise a
// plain line every 10 %, so that logs and pipes never get one line of carriage-return frames.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>

namespace loci {

inline bool StderrIsTerminal() {
  static const bool tty = isatty(fileno(stderr)) != 0;
  return tty;
}

// Whether `done` of `total` (done counts from 1) is one of the lines printed off a terminal:
// every 10 % and the last.
inline bool AtProgressStep(size_t done, size_t total) {
  const size_t step = std::max<size_t>(1, total / 10);
  return done % step == 0 || done >= total;
}

// "[####......]" for done of total.
inline std::string ProgressBar(size_t done, size_t total, int width) {
  const int filled =
      total == 0 ? width : static_cast<int>(width * std::min(done, total) / total);
  std::string bar = "[";  // appended, not "[" + std::string(...): GCC 12 -Wrestrict false positive
  bar.append(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(width - filled), '.');
  return bar + "]";
}

}  // namespace loci
