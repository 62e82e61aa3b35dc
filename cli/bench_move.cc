#include "cli/bench_move.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <thread>
#include <vector>

#include "common/time.h"
#include "server/map/product_codec.h"
#include "server/runtime/chunked_move.h"

namespace loci::cli {
namespace {

using Clock = std::chrono::steady_clock;

// The last n keyframes, moved by a small rigid correction (as a loop closure would move them).
std::vector<server::Mapper::KeyframePoseUpdate> LastKeyframesMoved(int64_t n,
                                                                   const server::Mapper& mapper) {
  SE3d T_fix = SE3d::Identity();
  T_fix.linear() = Eigen::AngleAxisd(0.02, Vec3d::UnitZ()).toRotationMatrix();
  T_fix.translation() = Vec3d(0.05, -0.03, 0.0);
  std::vector<server::Mapper::KeyframePoseUpdate> poses = mapper.KeyframePoses();
  const size_t keep = static_cast<size_t>(std::min<int64_t>(n, static_cast<int64_t>(poses.size())));
  std::vector<server::Mapper::KeyframePoseUpdate> updates(poses.end() - keep, poses.end());
  for (auto& u : updates) u.T_base_kf = T_fix * u.T_base_kf;
  return updates;
}

// What the mapping thread saw while the move ran.
struct MappingFigures {
  int64_t keyframes = 0;
  double longest_wait_ms = 0;
  double median_wait_ms = 0;
  double mean_map_ms = 0;
};

MappingFigures Summarise(std::vector<double> waits_ms, int64_t mapped, double map_ms_total) {
  MappingFigures f;
  f.keyframes = mapped;
  if (waits_ms.empty()) return f;
  std::sort(waits_ms.begin(), waits_ms.end());
  f.longest_wait_ms = waits_ms.back();
  f.median_wait_ms = waits_ms[waits_ms.size() / 2];
  f.mean_map_ms = mapped == 0 ? 0.0 : map_ms_total / static_cast<double>(mapped);
  return f;
}

}  // namespace

Status TimeMoveWhileMapping(int64_t n, int64_t chunk_keyframes, server::Mapper& mapper,
                            server::MapStore& store, const std::string& fingerprint,
                            const std::function<void()>& map_next) {
  const std::vector<server::Mapper::KeyframePoseUpdate> updates = LastKeyframesMoved(n, mapper);
  auto source = [&store, fingerprint](int64_t id) -> StatusOr<server::KeyframeProducts> {
    LOCI_ASSIGN_OR_RETURN(std::optional<std::string> bytes, store.GetProducts(id, fingerprint));
    if (!bytes) return absl::NotFoundError(absl::StrCat("no products for keyframe ", id));
    return server::DecodeProducts(*bytes, fingerprint, /*with_visibility=*/false);
  };
  mapper.FlushOctomap();  // the build's OctoMap backlog would share the cores with the move
  FifoMutex mapping_mu;
  std::atomic<bool> moving{true};
  std::vector<double> waits_ms;
  double map_ms_total = 0;
  int64_t mapped = 0;
  std::thread worker([&] {  // as the server's MapWorker, with its queue always full
    while (moving.load()) {
      {
        const Clock::time_point asked = Clock::now();
        std::lock_guard<FifoMutex> lock(mapping_mu);
        waits_ms.push_back(MsSince(asked));  // also the wait for the move's last chunk
        if (!moving.load()) break;
        const Clock::time_point t0 = Clock::now();
        map_next();
        map_ms_total += MsSince(t0);
        ++mapped;
      }
    }
  });
  const server::ChunkedMoveFigures moved = server::MoveInChunks(
      updates, static_cast<size_t>(chunk_keyframes), mapping_mu, [] { return absl::OkStatus(); },
      [&](const std::vector<server::Mapper::KeyframePoseUpdate>& chunk, bool last) {
        return mapper.UpdateKeyframePoses(chunk, source, /*rebuild_octomap=*/last);
      });
  moving = false;
  worker.join();
  LOCI_RETURN_IF_ERROR(moved.status);
  const MappingFigures m = Summarise(std::move(waits_ms), mapped, map_ms_total);
  std::printf("  moved %zu keyframes in %.3f s, %zu chunk(s) of at most %lld (0 = all at once); "
              "longest hold of the mapping lock %.0f ms\n",
              moved.moved, moved.total_ms / 1000.0, moved.chunks,
              static_cast<long long>(chunk_keyframes), moved.longest_hold_ms);
  std::printf("  mapping thread meanwhile: %lld keyframes mapped (%.1f ms each), waited for the "
              "lock at most %.0f ms (median %.1f ms)\n",
              static_cast<long long>(m.keyframes), m.mean_map_ms, m.longest_wait_ms,
              m.median_wait_ms);
  return absl::OkStatus();
}

}  // namespace loci::cli
