// Test helpers of the place tests: pose errors and their statistics, synthetic frames with
// features, block-shuffled images.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/se3.h"
#include "server/place/keyframe_features.h"
#include "synth/scene.h"

namespace loci::place::testing {

double Deg(double rad);

struct PoseError {
  double t_m = 0;
  double r_deg = 0;
};
// Error of `estimate` against `truth`: translation and angle of truth^-1 * estimate.
PoseError Error(const SE3d& truth, const SE3d& estimate);

class ErrorStats {
 public:
  void Add(const PoseError& e) { errors_.push_back(e); }
  size_t size() const { return errors_.size(); }
  double MedianT() const { return QuantileT(0.5); }
  double MedianR() const { return QuantileR(0.5); }
  double QuantileT(double q) const;
  double QuantileR(double q) const;
  // "n N, median X m Y deg, p90 ..., max ..."
  std::string Summary() const;

 private:
  std::vector<PoseError> errors_;
};

struct SyntheticFrame {
  SE3d T_world_cam = SE3d::Identity();
  KeyframeFeatures features;
  cv::Mat bgr, depth_m;  // the rendered images (depth in metres, 0 = none)
};
// Frame `index` of the scene's camera path, rendered (depth noise as the scene says) and with
// its features.
SyntheticFrame RenderSynthetic(const synth::Scene& scene, int index, const FeatureOptions& options);

// Every 15th of the first 300 frames (20 frames, 0.5 s apart) of the seed-3 synthetic room with
// Kinect-like depth noise, rendered with default features; empty when the scene cannot be made.
std::vector<SyntheticFrame> NoisyRoomFrames();

// Cuts bgr and depth into block_px squares and shuffles them (the same permutation for both).
void ShuffleBlocks(const cv::Mat& bgr, const cv::Mat& depth_m, int block_px, uint64_t seed,
                   cv::Mat* bgr_out, cv::Mat* depth_out);

}  // namespace loci::place::testing
