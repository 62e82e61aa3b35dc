// Process-wide heap tuning for a server that passes decoded images between threads.
//
// glibc serves large blocks (above M_MMAP_THRESHOLD, 128 KiB at start) with mmap and returns
// them on free, but its dynamic threshold rises to the size of each such block that is freed.
// After the first decoded 640x480 image is freed (0.9-1.2 MB), every later image comes from the
// heap arenas of whichever thread decoded it and is freed on another thread, and the arenas keep
// the pages: `loci bench ingest` grew by about 30 MB per 1000 keyframes that way, with a flat
// live heap (heaptrack). A fixed threshold keeps images on mmap and gives their pages back.
#pragma once

#include <cstddef>

namespace loci {

// Fixes glibc's mmap threshold at `bytes` (256 KiB: a decoded image is 4 times that, the map's
// own small allocations are far below it). Idempotent; a no-op on other C libraries.
void KeepLargeBlocksOnMmap(size_t bytes = 256 * 1024);

// Caps glibc's heap arenas at `arenas` (by default one per thread, up to 8 per core). Threads
// that build something large and short-lived (a pose-graph solve on the place-recognition
// thread) leave pages of their own arena resident after it is freed. `loci bench ingest
// --keyframes 2400` with loop closure ended 94.7-99.8 MB over its start with the default
// arenas (4 runs) and 81.9-85.0 MB with one (3 runs), at the same throughput; its growth
// figure while the queues are full is noisy either way.
// Threads that allocated before the call keep their arenas, so main() calls it first;
// idempotent; a no-op on other C libraries.
void LimitHeapArenas(int arenas = 1);

// Gives the free pages of every heap arena back to the system (glibc malloc_trim), after work
// whose transient peak grows with the map (a pose-graph solve builds the whole graph anew) and
// after each checkpoint (a map without loop closure has no solves).
// A no-op on other C libraries.
void ReleaseFreeHeapPages();

}  // namespace loci
