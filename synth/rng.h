// Deterministic random numbers for scene generation. SplitMix64 with our own distributions, so
// a seed gives the same scene with any standard library (std::*_distribution are
// implementation-defined).
#pragma once

#include <cmath>
#include <cstdint>

namespace loci::synth {

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}

  // Mixes several values into one seed (frame stamps, row indices ...).
  static uint64_t Mix(uint64_t a, uint64_t b) {
    Rng r(a ^ (b + 0x9E3779B97F4A7C15ULL + (a << 6) + (a >> 2)));
    return r.Next();
  }

  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  // Uniform in [lo, hi).
  double Uniform(double lo = 0.0, double hi = 1.0) {
    return lo + (hi - lo) * (static_cast<double>(Next() >> 11) * 0x1.0p-53);
  }
  // Uniform integer in [lo, hi] (inclusive).
  int UniformInt(int lo, int hi) {
    if (hi <= lo) return lo;
    return lo + static_cast<int>(Next() % static_cast<uint64_t>(hi - lo + 1));
  }
  bool Bernoulli(double p) { return Uniform() < p; }
  // Standard normal (Box-Muller; the second value of each pair is kept for the next call).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace loci::synth
