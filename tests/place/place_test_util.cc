#include "tests/place/place_test_util.h"

#include <algorithm>
#include <cstdio>
#include <numbers>
#include <random>

#include "synth/renderer.h"

namespace loci::place::testing {

double Deg(double rad) { return rad * 180.0 / std::numbers::pi; }

PoseError Error(const SE3d& truth, const SE3d& estimate) {
  const SE3d d = truth.inverse() * estimate;
  return {d.translation().norm(), Deg(RotationAngleRad(d))};
}

namespace {
double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}
}  // namespace

double ErrorStats::QuantileT(double q) const {
  std::vector<double> v;
  for (const PoseError& e : errors_) v.push_back(e.t_m);
  return Quantile(v, q);
}

double ErrorStats::QuantileR(double q) const {
  std::vector<double> v;
  for (const PoseError& e : errors_) v.push_back(e.r_deg);
  return Quantile(v, q);
}

std::string ErrorStats::Summary() const {
  char s[200];
  std::snprintf(
      s, sizeof(s), "n %zu, median %.3f m %.2f deg, p90 %.3f m %.2f deg, max %.3f m %.2f deg",
      size(), MedianT(), MedianR(), QuantileT(0.9), QuantileR(0.9), QuantileT(1.0), QuantileR(1.0));
  return s;
}

SyntheticFrame RenderSynthetic(const synth::Scene& scene, int index,
                               const FeatureOptions& options) {
  const int64_t t_ns = synth::FrameStampNs(scene.options, index);
  SyntheticFrame out;
  out.T_world_cam = synth::CameraPoseAt(scene, t_ns);
  const synth::RenderedFrame r = synth::Render(scene, out.T_world_cam, scene.camera, t_ns);
  cv::Mat depth_m;
  r.depth_u16.convertTo(depth_m, CV_32F, 1.0 / scene.options.depth_scale);
  auto f = ExtractFeatures(r.bgr, depth_m, scene.camera, options);
  if (f.ok()) out.features = std::move(*f);
  out.bgr = r.bgr;
  out.depth_m = depth_m;
  return out;
}

std::vector<SyntheticFrame> NoisyRoomFrames() {
  synth::SceneOptions so;
  so.seed = 3;
  so.depth_noise = true;
  auto scene = synth::MakeScene(so);
  std::vector<SyntheticFrame> frames;
  if (!scene.ok()) return frames;
  for (int i = 0; i < 300; i += 15) frames.push_back(RenderSynthetic(*scene, i, FeatureOptions{}));
  return frames;
}

void ShuffleBlocks(const cv::Mat& bgr, const cv::Mat& depth_m, int block_px, uint64_t seed,
                   cv::Mat* bgr_out, cv::Mat* depth_out) {
  const int cols = bgr.cols / block_px, rows = bgr.rows / block_px;
  std::vector<int> order(static_cast<size_t>(cols * rows));
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::shuffle(order.begin(), order.end(), std::mt19937_64(seed));
  *bgr_out = bgr.clone();
  *depth_out = depth_m.clone();
  for (size_t i = 0; i < order.size(); ++i) {
    const cv::Rect from((order[i] % cols) * block_px, (order[i] / cols) * block_px, block_px,
                        block_px);
    const cv::Rect to((static_cast<int>(i) % cols) * block_px,
                      (static_cast<int>(i) / cols) * block_px, block_px, block_px);
    bgr(from).copyTo((*bgr_out)(to));
    depth_m(from).copyTo((*depth_out)(to));
  }
}

}  // namespace loci::place::testing
