#include "detection/depth_mask.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/config.h"

namespace loci::detection {

StatusOr<MaskOptions> MaskOptions::FromYaml(const YAML::Node& node) {
  MaskOptions o;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "depth_scale", &o.depth_scale));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_depth_m", &o.min_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_depth_m", &o.max_depth_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "bin_width_rel", &o.bin_width_rel));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "centre_sigma_rel", &o.centre_sigma_rel));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_bin_fraction", &o.min_bin_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_gap_bins", &o.max_gap_bins));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_pixels", &o.min_pixels));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "largest_component", &o.largest_component));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "morph_kernel_px", &o.morph_kernel_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "remove_support_plane", &o.remove_support_plane));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "plane_tolerance_m", &o.plane_tolerance_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "plane_tolerance_sigma", &o.plane_tolerance_sigma));
  LOCI_RETURN_IF_ERROR(o.Validate());
  return o;
}

Status MaskOptions::Validate() const {
  if (!(depth_scale > 0.f)) return absl::InvalidArgumentError("mask.depth_scale must be > 0");
  if (!(min_depth_m > 0.f && max_depth_m > min_depth_m)) {
    return absl::InvalidArgumentError("mask: need 0 < min_depth_m < max_depth_m");
  }
  if (!(bin_width_rel > 0.f && bin_width_rel < 1.f)) {
    return absl::InvalidArgumentError("mask.bin_width_rel must be in (0, 1)");
  }
  if (!(centre_sigma_rel > 0.f)) {
    return absl::InvalidArgumentError("mask.centre_sigma_rel must be > 0");
  }
  if (!(min_bin_fraction >= 0.f && min_bin_fraction < 1.f) || max_gap_bins < 0 || min_pixels < 1 ||
      morph_kernel_px < 0) {
    return absl::InvalidArgumentError("mask: invalid cluster or morphology parameter");
  }
  return absl::OkStatus();
}

namespace {

// Inverse-depth plane w = a u + b v + c (any 3-D plane seen by a pinhole camera).
struct InversePlane {
  double a = 0, b = 0, c = 0;
  bool Fit(const cv::Point3d& p, const cv::Point3d& q, const cv::Point3d& r) {
    cv::Matx33d A(p.x, p.y, 1, q.x, q.y, 1, r.x, r.y, 1);
    cv::Vec3d w(1.0 / p.z, 1.0 / q.z, 1.0 / r.z), x;
    if (std::abs(cv::determinant(A)) < 1e-6 || !cv::solve(A, w, x)) return false;
    a = x[0];
    b = x[1];
    c = x[2];
    return true;
  }
  bool Inlier(double u, double v, double z, const MaskOptions& o) const {
    const double w = a * u + b * v + c;
    if (w <= 0) return false;
    const double tol =
        std::max<double>(o.plane_tolerance_m, o.plane_tolerance_sigma * 0.0015 * z * z);
    return std::abs(z - 1.0 / w) < tol;
  }
};

// Depth in metres at (u, v) of a CV_16U or CV_32F image; 0 when invalid.
double DepthAt(const cv::Mat& depth, int u, int v, const MaskOptions& o) {
  const double z =
      depth.depth() == CV_16U ? depth.at<uint16_t>(v, u) / o.depth_scale : depth.at<float>(v, u);
  return z >= o.min_depth_m && z <= o.max_depth_m ? z : 0.0;
}

// Removes from `mask` (pixels of depth_m = depth(roi)) a plane that holds >= 30 % of the mask's
// pixels near the box border, few of its central pixels (not the object's own face), and
// continues outside the box (a box is tight on its object: a surface that extends beyond it
// is support or background; the rim of a curved object does not).
void RemoveSupportPlane(const cv::Mat& depth, const cv::Rect& roi, const cv::Mat& depth_m,
                        const MaskOptions& o, cv::Mat* mask) {
  const int w = mask->cols, h = mask->rows;
  const int band_x = std::max(2, w * 15 / 100), band_y = std::max(2, h * 15 / 100);
  std::vector<cv::Point3d> band, centre;
  for (int v = 0; v < h; ++v) {
    const uint8_t* m = mask->ptr<uint8_t>(v);
    const float* d = depth_m.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      if (!m[u] || !(d[u] > 0.f)) continue;
      if (u < band_x || u >= w - band_x || v < band_y || v >= h - band_y) {
        band.emplace_back(u, v, d[u]);
      } else if (std::abs(u - w / 2) < w * 0.2 && std::abs(v - h / 2) < h * 0.2) {
        centre.emplace_back(u, v, d[u]);
      }
    }
  }
  if (band.size() < 30) return;
  std::mt19937 rng(12345);  // deterministic: the same frame gives the same mask
  std::uniform_int_distribution<size_t> pick(0, band.size() - 1);
  InversePlane best;
  size_t best_inliers = 0;
  for (int it = 0; it < 64; ++it) {
    InversePlane p;
    if (!p.Fit(band[pick(rng)], band[pick(rng)], band[pick(rng)])) continue;
    size_t n = 0;
    for (const auto& q : band) n += p.Inlier(q.x, q.y, q.z, o);
    if (n > best_inliers) {
      best_inliers = n;
      best = p;
    }
  }
  if (best_inliers < 0.3 * band.size()) return;
  size_t centre_in = 0;
  for (const auto& q : centre) centre_in += best.Inlier(q.x, q.y, q.z, o);
  if (centre.empty() || centre_in > 0.3 * centre.size()) return;  // the object's own face
  // Ring outside the box, in roi coordinates.
  const int near_px = std::max(3, std::max(w, h) / 20), far_px = std::max(8, std::max(w, h) / 6);
  const cv::Rect image(0, 0, depth.cols, depth.rows);
  const cv::Rect outer =
      cv::Rect(roi.x - far_px, roi.y - far_px, w + 2 * far_px, h + 2 * far_px) & image;
  const cv::Rect inner =
      cv::Rect(roi.x - near_px, roi.y - near_px, w + 2 * near_px, h + 2 * near_px);
  size_t outside = 0, outside_in = 0;
  for (int v = outer.y; v < outer.br().y; v += 2) {
    for (int u = outer.x; u < outer.br().x; u += 2) {
      if (inner.contains(cv::Point(u, v))) continue;
      const double z = DepthAt(depth, u, v, o);
      if (z <= 0.0) continue;
      ++outside;
      outside_in += best.Inlier(u - roi.x, v - roi.y, z, o);
    }
  }
  if (outside < 10 || outside_in < 0.25 * outside) return;  // ends at the box: object surface
  cv::Mat out = mask->clone();
  for (int v = 0; v < h; ++v) {
    uint8_t* m = out.ptr<uint8_t>(v);
    const float* d = depth_m.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      if (m[u] && d[u] > 0.f && best.Inlier(u, v, d[u], o)) m[u] = 0;
    }
  }
  if (cv::countNonZero(out) >= o.min_pixels) *mask = out;
}

// Keeps the 8-connected component of `mask` with the largest summed weight.
void KeepHeaviestComponent(const cv::Mat& weight, cv::Mat* mask) {
  cv::Mat labels;
  const int n = cv::connectedComponents(*mask, labels, 8, CV_32S);
  if (n <= 2) return;
  std::vector<double> score(n, 0.0);
  for (int v = 0; v < mask->rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const float* w = weight.ptr<float>(v);
    for (int u = 0; u < mask->cols; ++u) score[l[u]] += l[u] > 0 ? w[u] : 0.0;
  }
  const int best =
      static_cast<int>(std::max_element(score.begin() + 1, score.end()) - score.begin());
  *mask = (labels == best);
}

}  // namespace

cv::Mat SegmentObjectDepth(const cv::Mat& depth, const cv::Rect2f& box_px, const MaskOptions& o) {
  if (depth.empty() || depth.channels() != 1 ||
      (depth.depth() != CV_16U && depth.depth() != CV_32F)) {
    return {};
  }
  const cv::Rect roi = MaskRect(box_px, depth.cols, depth.rows);
  if (roi.width <= 0 || roi.height <= 0) return {};
  cv::Mat depth_m;
  if (depth.depth() == CV_16U) {
    depth(roi).convertTo(depth_m, CV_32F, 1.0 / o.depth_scale);
  } else {
    depth_m = depth(roi).clone();
  }
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8UC1);

  // Centre-weighted histogram over log-depth bins.
  const double log_min = std::log(o.min_depth_m);
  const double log_step = std::log1p(o.bin_width_rel);
  const int num_bins =
      static_cast<int>(std::ceil((std::log(o.max_depth_m) - log_min) / log_step)) + 1;
  std::vector<double> hist(num_bins, 0.0);
  cv::Mat bin_of(roi.size(), CV_32S, cv::Scalar(-1));
  cv::Mat weight(roi.size(), CV_32F);
  const double cx = box_px.x + box_px.width * 0.5 - roi.x;
  const double cy = box_px.y + box_px.height * 0.5 - roi.y;
  const double sx = std::max(1.0, double{o.centre_sigma_rel} * box_px.width);
  const double sy = std::max(1.0, double{o.centre_sigma_rel} * box_px.height);
  // The Gaussian is separable: exp(-(dx^2 + dy^2) / 2) = wx(u) * wy(v).
  std::vector<float> wx(roi.width);
  for (int u = 0; u < roi.width; ++u) {
    const double dx = (u + 0.5 - cx) / sx;
    wx[u] = static_cast<float>(std::exp(-0.5 * dx * dx));
  }
  int valid = 0;
  for (int v = 0; v < roi.height; ++v) {
    const float* d = depth_m.ptr<float>(v);
    int* b = bin_of.ptr<int>(v);
    float* w = weight.ptr<float>(v);
    const double dy = (v + 0.5 - cy) / sy;
    const float wy = static_cast<float>(std::exp(-0.5 * dy * dy));
    for (int u = 0; u < roi.width; ++u) {
      w[u] = wx[u] * wy;
      if (!(d[u] >= o.min_depth_m && d[u] <= o.max_depth_m)) continue;
      b[u] = std::clamp(static_cast<int>((std::log(d[u]) - log_min) / log_step), 0, num_bins - 1);
      hist[b[u]] += w[u];
      ++valid;
    }
  }
  if (valid < o.min_pixels) return mask;

  // Smooth with [1 2 1] so a surface straddling two bins is not split.
  std::vector<double> smooth(num_bins, 0.0);
  for (int i = 0; i < num_bins; ++i) {
    smooth[i] = 2 * hist[i] + (i > 0 ? hist[i - 1] : 0.0) + (i + 1 < num_bins ? hist[i + 1] : 0.0);
  }
  // Depth clusters: runs of bins above floor_weight, bridging at most max_gap_bins weaker ones.
  const double floor_weight = o.min_bin_fraction * *std::max_element(smooth.begin(), smooth.end());
  struct Cluster {
    int lo, hi;
    double weight;
  };
  std::vector<Cluster> clusters;
  for (int i = 0, gap = 0; i < num_bins; ++i) {
    if (hist[i] <= floor_weight) {
      ++gap;
      continue;
    }
    if (clusters.empty() || gap > o.max_gap_bins) clusters.push_back({i, i, 0.0});
    clusters.back().hi = i;
    clusters.back().weight += hist[i];
    gap = 0;
  }
  std::sort(clusters.begin(), clusters.end(),
            [](const Cluster& a, const Cluster& b) { return a.weight > b.weight; });
  if (clusters.size() > 3) clusters.resize(3);

  // Small boxes (thin objects) lose too much to morphology.
  const int kernel =
      std::min(roi.width, roi.height) >= 8 * o.morph_kernel_px ? o.morph_kernel_px : 1;
  // Each candidate cluster -> its best connected component, scored by centre weight times how
  // much of the box it spans (a detector's box is tight on the object's visible pixels, while
  // an occluder in front or a patch of background rarely spans it).
  double best_score = -1.0;
  for (const Cluster& c : clusters) {
    cv::Mat m(roi.size(), CV_8UC1);
    for (int v = 0; v < roi.height; ++v) {
      const int* b = bin_of.ptr<int>(v);
      uint8_t* row = m.ptr<uint8_t>(v);
      for (int u = 0; u < roi.width; ++u) row[u] = (b[u] >= c.lo && b[u] <= c.hi) ? 255 : 0;
    }
    if (kernel > 1) {
      cv::morphologyEx(m, m, cv::MORPH_OPEN,
                       cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kernel, kernel)));
    }
    cv::Mat labels;
    const int n = cv::connectedComponents(m, labels, 8, CV_32S);
    if (n < 2) continue;
    std::vector<double> score(n, 0.0);
    for (int v = 0; v < roi.height; ++v) {
      const int* l = labels.ptr<int>(v);
      const float* w = weight.ptr<float>(v);
      for (int u = 0; u < roi.width; ++u) score[l[u]] += l[u] > 0 ? w[u] : 0.0;
    }
    if (o.largest_component && n > 2) {
      const int best =
          static_cast<int>(std::max_element(score.begin() + 1, score.end()) - score.begin());
      m = (labels == best);
      score[1] = score[best];
    } else {
      for (int k = 2; k < n; ++k) score[1] += score[k];
    }
    const cv::Rect extent = cv::boundingRect(m);
    const double span = (static_cast<double>(extent.width) / roi.width) *
                        (static_cast<double>(extent.height) / roi.height);
    if (score[1] * span > best_score) {
      best_score = score[1] * span;
      mask = m;
    }
  }
  if (o.remove_support_plane && !mask.empty() && cv::countNonZero(mask) > 0) {
    RemoveSupportPlane(depth, roi, depth_m, o, &mask);
    if (kernel > 1) {
      cv::morphologyEx(mask, mask, cv::MORPH_OPEN,
                       cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kernel, kernel)));
    }
    if (o.largest_component) KeepHeaviestComponent(weight, &mask);
  }
  if (kernel > 1) {
    const cv::Mat k = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kernel, kernel));
    // Close fills pinholes of missing depth inside the object, never pixels of other depth.
    cv::Mat closed;
    cv::morphologyEx(mask, closed, cv::MORPH_CLOSE, k);
    for (int v = 0; v < roi.height; ++v) {
      const int* b = bin_of.ptr<int>(v);
      const uint8_t* c = closed.ptr<uint8_t>(v);
      uint8_t* m = mask.ptr<uint8_t>(v);
      for (int u = 0; u < roi.width; ++u) {
        if (c[u] && b[u] < 0) m[u] = 255;
      }
    }
  }
  return mask;
}

void AttachDepthMasks(const cv::Mat& depth, std::vector<Detection2D>* detections,
                      const MaskOptions& options) {
  for (Detection2D& d : *detections) {
    cv::Mat m = SegmentObjectDepth(depth, d.box_px, options);
    if (!m.empty() && cv::countNonZero(m) > 0) d.mask = m;
  }
}

}  // namespace loci::detection
