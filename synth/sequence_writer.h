// Writes a synthetic scene as a TUM RGB-D folder plus ground truth:
//   rgb/<stamp>.jpg (JPEG), depth/<stamp>.png (16-bit, depth_scale per metre), rgb.txt,
//   depth.txt (same stamps), groundtruth.txt (T_world_cam, world z up), accelerometer.txt,
//   camera.yaml (schema of config/camera_tum_fr1.yaml), objects.json, detections.jsonl and
//   synth.yaml (the options, to regenerate the folder).
#pragma once

#include <string>

#include "common/status.h"
#include "common/tum_io.h"
#include "synth/scene.h"

namespace loci::synth {

struct SequenceStats {
  int frames = 0;
  int objects = 0;         // objects in objects.json (table and shelf included)
  int64_t detections = 0;  // detections written, all frames
  double seconds = 0;      // wall time of WriteSequence
};

// Accelerometer samples of the scene's camera path (TUM/Kinect axes, see GravityInCamAt in
// common/tum_io.h): a = (-f_x, -f_y, f_z) with f_cam = R_cam_world (acc_world + 9.81 z_world),
// the specific force; acc_world = 0 when !options.accel_with_motion. One sample every
// 1/accel_rate_hz from the first to the last frame stamp.
std::vector<AccelSample> MakeAccelerometer(const Scene& scene);

// Renders options.num_frames frames (frames in parallel over options.num_threads) into out_dir
// (created if needed; existing files are overwritten).
Status WriteSequence(const SceneOptions& options, const std::string& out_dir,
                     SequenceStats* stats = nullptr);

}  // namespace loci::synth
