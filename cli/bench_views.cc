#include "cli/bench_views.h"

#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/image_codec.h"
#include "common/time.h"
#include "common/tum_io.h"
#include "proto/convert.h"
#include "synth/sequence_writer.h"

namespace loci::cli {

double RssMb() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_rss = 0;
  statm >> pages_total >> pages_rss;
  return static_cast<double>(pages_rss) * sysconf(_SC_PAGESIZE) / (1024.0 * 1024.0);
}

double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // KiB on Linux
}

double LiveHeapMb() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 info = mallinfo2();
  return static_cast<double>(info.uordblks + info.hblkhd) / (1024.0 * 1024.0);
#else
  return 0.0;
#endif
}

StatusOr<std::vector<loci::v1::Keyframe>> RenderViews(const synth::SceneOptions& options,
                                                      const std::string& dir) {
  LOCI_RETURN_IF_ERROR(synth::WriteSequence(options, dir + "/scene"));
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(dir + "/scene"));
  LOCI_ASSIGN_OR_RETURN(auto detections, ReadDetectionsJsonl(dir + "/scene/detections.jsonl"));
  std::vector<loci::v1::Keyframe> out;
  for (const TumFrame& f : seq.frames) {
    loci::v1::Keyframe kf;
    LOCI_ASSIGN_OR_RETURN(*kf.mutable_rgb_jpeg(), ReadFileBytes(f.rgb_path));
    LOCI_ASSIGN_OR_RETURN(*kf.mutable_depth_png(), ReadFileBytes(f.depth_path));
    const StampedPose* pose = NearestByTime<StampedPose>(seq.groundtruth, f.rgb_t_ns, INT64_MAX);
    ToProto(pose != nullptr ? pose->T_world_cam : SE3d::Identity(), kf.mutable_t_odom_cam());
    if (const FrameDetections* fd = FindDetections(detections, f.rgb_t_ns)) {
      for (const Detection2D& d : fd->detections) {
        LOCI_RETURN_IF_ERROR(ToProto(d, kf.add_detections()));
      }
    }
    kf.set_t_ns(f.rgb_t_ns);
    out.push_back(std::move(kf));
  }
  if (out.empty()) return absl::InternalError("the synthetic scene has no frames");
  return out;
}

loci::v1::Keyframe NthKeyframe(const std::vector<loci::v1::Keyframe>& views, int64_t i,
                               const std::string& session_id) {
  const int64_t n = static_cast<int64_t>(views.size());
  const int64_t period_ns = views.back().t_ns() - views.front().t_ns() + 33'000'000;
  loci::v1::Keyframe kf = views[static_cast<size_t>(i % n)];
  kf.set_session_id(session_id);
  kf.set_seq(i);
  kf.set_t_ns(kf.t_ns() + (i / n) * period_ns);
  return kf;
}

loci::v1::OpenSessionRequest BenchOpenRequest(const std::string& robot, double depth_scale) {
  loci::v1::OpenSessionRequest open;
  open.set_robot_name(robot);
  const PinholeCamera cam = PinholeCamera::TumFr1();
  loci::ToProto(cam, open.mutable_intrinsics());
  open.set_depth_scale(depth_scale);
  return open;
}

}  // namespace loci::cli
