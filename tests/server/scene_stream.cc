#include "tests/server/scene_stream.h"

#include <cstdlib>
#include <filesystem>

#include "common/detections_io.h"
#include "common/image_codec.h"
#include "common/tum_io.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server::testing {

StatusOr<std::vector<loci::v1::Keyframe>> LoadSceneKeyframes(const std::string& dir,
                                                             int every_nth) {
  LOCI_ASSIGN_OR_RETURN(TumSequence seq, LoadTumSequence(dir));
  // A real recording without detections.jsonl: keyframes without boxes (the server detects).
  std::vector<FrameDetections> detections;
  if (std::filesystem::exists(dir + "/detections.jsonl")) {
    LOCI_ASSIGN_OR_RETURN(detections, ReadDetectionsJsonl(dir + "/detections.jsonl"));
  }
  std::vector<loci::v1::Keyframe> out;
  for (size_t i = 0; i < seq.frames.size(); i += every_nth) {
    const TumFrame& f = seq.frames[i];
    // The nearest ground-truth pose (a synthetic scene has one at each frame's stamp; a real
    // recording's motion capture runs at about 100 Hz).
    const StampedPose* pose = nullptr;
    for (const StampedPose& p : seq.groundtruth) {
      if (!pose || std::llabs(p.t_ns - f.rgb_t_ns) < std::llabs(pose->t_ns - f.rgb_t_ns)) pose = &p;
    }
    if (pose == nullptr || std::llabs(pose->t_ns - f.rgb_t_ns) > 20'000'000) {
      return absl::NotFoundError("no ground-truth pose within 20 ms of a frame");
    }
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
