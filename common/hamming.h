// A 256-bit binary descriptor (ORB) as four 64-bit words, its Hamming distance, and
// LOCI_POPCNT_CLONES for the loops that compute many of them.
#pragma once

#include <array>
#include <bit>
#include <cstdint>

// A function marked with this is compiled twice, with the POPCNT instruction and without, and
// picked at load time (glibc ifunc): std::popcount is one instruction with it and a libgcc call
// without, and Debian's amd64 baseline does not guarantee it. Not in a ThreadSanitizer build:
// GCC instruments the ifunc resolver with __tsan_func_entry, and the resolver runs while the
// dynamic loader relocates the binary, before the TSan runtime is set up, so every binary
// holding such a function crashed at load (docs/sanitizers.md). Only on x86-64.
#if defined(__SANITIZE_THREAD__) || !defined(__x86_64__)
#define LOCI_POPCNT_CLONES
#else
#define LOCI_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#endif

namespace loci {

using Descriptor256 = std::array<uint64_t, 4>;

inline int Hamming(const Descriptor256& a, const Descriptor256& b) {
  return std::popcount(a[0] ^ b[0]) + std::popcount(a[1] ^ b[1]) + std::popcount(a[2] ^ b[2]) +
         std::popcount(a[3] ^ b[3]);
}

}  // namespace loci
