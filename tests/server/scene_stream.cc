#include "tests/server/scene_stream.h"

#include <cstdlib>

#include "common/detections_io.h"
#include "common/image_codec.h"
#include "common/tum_io.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server::testing {

StatusOr<std::vector<loci::v1::Keyframe>> LoadSceneKeyframes(const std::string& dir,
                                                             int every_nth) {
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(dir));
  LOCI_ASSIGN_OR_RETURN(auto detections, ReadDetectionsJsonl(dir + "/detections.jsonl"));
  std::vector<loci::v1::Keyframe> out;
  for (size_t i = 0; i < seq.frames.size(); i += every_nth) {
    const TumFrame& f = seq.frames[i];
    const StampedPose* pose = nullptr;
    for (const StampedPose& p : seq.groundtruth) {
      if (std::llabs(p.t_ns - f.rgb_t_ns) < 1'000'000) pose = &p;
    }
    if (pose == nullptr) return absl::NotFoundError("no ground-truth pose for a frame");
    LOCI_ASSIGN_OR_RETURN(std::string rgb, ReadFileBytes(f.rgb_path));
    LOCI_ASSIGN_OR_RETURN(std::string depth, ReadFileBytes(f.depth_path));
    std::optional<Eigen::Vector3d> gravity;
    if (!seq.accel.empty()) {
      auto g = GravityInCamAt(seq.accel, f.rgb_t_ns);
      if (g.ok()) gravity = *g;
    }
    const FrameDetections* fd = FindDetections(detections, f.rgb_t_ns);
    out.push_back(MakeKeyframeFromBytes("", static_cast<int64_t>(out.size()), f.rgb_t_ns,
                                        pose->T_world_cam, std::move(rgb), std::move(depth),
                                        fd ? fd->detections : std::vector<Detection2D>{}, gravity));
  }
  return out;
}

}  // namespace loci::server::testing
