#include "synth/depth_noise.h"

#include <algorithm>
#include <cmath>

#include "synth/rng.h"

namespace loci::synth {

double KinectSigmaM(double z_m) { return 0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4); }

cv::Mat ApplyKinectNoise(const cv::Mat& depth_m, uint64_t seed, const DepthNoiseOptions& o) {
  CV_Assert(depth_m.type() == CV_32FC1);
  cv::Mat out(depth_m.size(), CV_32FC1, cv::Scalar(0));
  const double fb = o.focal_px * o.baseline_m;  // disparity (px) times depth (m)
  for (int y = 0; y < depth_m.rows; ++y) {
    Rng rng(Rng::Mix(seed, static_cast<uint64_t>(y)));
    const float* prev = depth_m.ptr<float>(std::max(y - 1, 0));
    const float* row = depth_m.ptr<float>(y);
    const float* next = depth_m.ptr<float>(std::min(y + 1, depth_m.rows - 1));
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const double z = row[x];
      if (!(z > 0)) continue;
      const double jump = o.edge_jump_ratio * z;
      const float neighbours[4] = {prev[x], next[x], row[std::max(x - 1, 0)],
                                   row[std::min(x + 1, depth_m.cols - 1)]};
      bool edge = false;
      for (float n : neighbours) edge = edge || n <= 0 || std::abs(n - z) > jump;
      if (edge && rng.Bernoulli(o.edge_dropout_prob)) continue;
      const double zn = std::max(0.05, z + KinectSigmaM(z) * rng.Normal());
      const double disparity = std::round(fb / zn * o.subpixel) / o.subpixel;
      if (disparity <= 0) continue;
      dst[x] = static_cast<float>(fb / disparity);
    }
  }
  return out;
}

}  // namespace loci::synth
