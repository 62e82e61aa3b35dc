#include "client/tracking/orb_frame.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

namespace loci {

void OrbFrame::FeaturesInRadius(double u, double v, double radius_px, int min_level, int max_level,
                                std::vector<int>* out) const {
  out->clear();
  const int c0 = std::max(0, static_cast<int>(std::floor((u - radius_px) / kCellPx)));
  const int c1 = std::min(grid_cols - 1, static_cast<int>(std::floor((u + radius_px) / kCellPx)));
  const int r0 = std::max(0, static_cast<int>(std::floor((v - radius_px) / kCellPx)));
  const int r1 = std::min(grid_rows - 1, static_cast<int>(std::floor((v + radius_px) / kCellPx)));
  const double r2 = radius_px * radius_px;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      for (int i : grid[r * grid_cols + c]) {
        const cv::KeyPoint& kp = keypoints[i];
        if (kp.octave < min_level || kp.octave > max_level) continue;
        const double du = kp.pt.x - u, dv = kp.pt.y - v;
        if (du * du + dv * dv <= r2) out->push_back(i);
      }
    }
  }
}

OrbExtractor::OrbExtractor(const TrackerOptions& options) : opt_(options) {
  // Twice the target so the grid selection has candidates in every cell.
  orb_ = cv::ORB::create(opt_.orb.num_features * 2, opt_.orb.scale_factor, opt_.orb.num_levels,
                         /*edgeThreshold=*/19, /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE,
                         /*patchSize=*/31, opt_.orb.fast_threshold);
  level_scale_.resize(opt_.orb.num_levels);
  for (int l = 0; l < opt_.orb.num_levels; ++l) {
    level_scale_[l] = std::pow(opt_.orb.scale_factor, static_cast<float>(l));
  }
}

float OrbExtractor::LevelScale(int octave) const {
  return level_scale_[std::clamp(octave, 0, static_cast<int>(level_scale_.size()) - 1)];
}

OrbFrame OrbExtractor::Extract(const cv::Mat& gray, const cv::Mat& depth_m, int64_t t_ns) const {
  OrbFrame f;
  f.t_ns = t_ns;
  f.width_px = gray.cols;
  f.height_px = gray.rows;
  std::vector<cv::KeyPoint> all;
  orb_->detect(gray, all);

  // Grid distribution: each cell keeps its strongest share, the rest goes to the strongest left.
  const int cells = opt_.orb.grid_cols * opt_.orb.grid_rows;
  const int quota = std::max(1, opt_.orb.num_features / cells);
  std::vector<int> order(all.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return all[a].response > all[b].response; });
  std::vector<int> per_cell(cells, 0);
  std::vector<char> taken(all.size(), 0);
  std::vector<cv::KeyPoint> kept;
  kept.reserve(opt_.orb.num_features);
  for (int i : order) {
    const int cx = std::min(opt_.orb.grid_cols - 1,
                            static_cast<int>(all[i].pt.x * opt_.orb.grid_cols / gray.cols));
    const int cy = std::min(opt_.orb.grid_rows - 1,
                            static_cast<int>(all[i].pt.y * opt_.orb.grid_rows / gray.rows));
    int& n = per_cell[cy * opt_.orb.grid_cols + cx];
    if (n < quota) {
      ++n;
      taken[i] = 1;
      kept.push_back(all[i]);
    }
  }
  for (int i : order) {
    if (static_cast<int>(kept.size()) >= opt_.orb.num_features) break;
    if (!taken[i]) kept.push_back(all[i]);
  }
  cv::Mat desc;
  orb_->compute(gray, kept, desc);  // may drop keypoints near the border

  f.keypoints = std::move(kept);
  const size_t n = f.keypoints.size();
  f.descriptors.resize(n);
  f.depth_m.assign(n, 0.f);
  f.p_cam.assign(n, Eigen::Vector3d::Zero());
  f.class_weight.assign(n, -1.f);
  const PinholeCamera& cam = opt_.camera;
  for (size_t i = 0; i < n; ++i) {
    std::memcpy(f.descriptors[i].data(), desc.ptr<uint8_t>(static_cast<int>(i)), 32);
    const cv::KeyPoint& kp = f.keypoints[i];
    const int u = static_cast<int>(std::lround(kp.pt.x));
    const int v = static_cast<int>(std::lround(kp.pt.y));
    if (depth_m.empty() || u < 0 || v < 0 || u >= depth_m.cols || v >= depth_m.rows) continue;
    const float z = depth_m.at<float>(v, u);
    if (z < opt_.min_depth_m || z > opt_.max_depth_m) continue;
    // Corners often sit on depth edges, where the (not exactly synchronised) depth image mixes
    // foreground and background: keep the depth only when the 3x3 neighbourhood agrees.
    bool consistent = true;
    for (int dv = -1; dv <= 1 && consistent; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const int uu = std::clamp(u + du, 0, depth_m.cols - 1);
        const int vv = std::clamp(v + dv, 0, depth_m.rows - 1);
        const float zn = depth_m.at<float>(vv, uu);
        if (zn <= 0 || std::abs(zn - z) > opt_.depth_edge_ratio * z) {
          consistent = false;
          break;
        }
      }
    }
    if (consistent) {
      f.depth_m[i] = z;
      f.p_cam[i] = cam.BackProject(kp.pt.x, kp.pt.y, z);
    }
  }
  f.grid_cols = (f.width_px + OrbFrame::kCellPx - 1) / OrbFrame::kCellPx;
  f.grid_rows = (f.height_px + OrbFrame::kCellPx - 1) / OrbFrame::kCellPx;
  f.grid.assign(static_cast<size_t>(f.grid_cols) * f.grid_rows, {});
  for (size_t i = 0; i < n; ++i) {
    const int c =
        std::clamp(static_cast<int>(f.keypoints[i].pt.x) / OrbFrame::kCellPx, 0, f.grid_cols - 1);
    const int r =
        std::clamp(static_cast<int>(f.keypoints[i].pt.y) / OrbFrame::kCellPx, 0, f.grid_rows - 1);
    f.grid[r * f.grid_cols + c].push_back(static_cast<int>(i));
  }
  return f;
}

}  // namespace loci
