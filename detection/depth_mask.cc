#include "detection/depth_mask.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

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
  int valid = 0;
  for (int v = 0; v < roi.height; ++v) {
    const float* d = depth_m.ptr<float>(v);
    int* b = bin_of.ptr<int>(v);
    float* w = weight.ptr<float>(v);
    const double dy = (v + 0.5 - cy) / sy;
    for (int u = 0; u < roi.width; ++u) {
      const double dx = (u + 0.5 - cx) / sx;
      w[u] = static_cast<float>(std::exp(-0.5 * (dx * dx + dy * dy)));
      if (!(d[u] >= o.min_depth_m && d[u] <= o.max_depth_m)) continue;
      b[u] = std::clamp(static_cast<int>((std::log(d[u]) - log_min) / log_step), 0, num_bins - 1);
      hist[b[u]] += w[u];
      ++valid;
    }
  }
  if (valid < o.min_pixels) return mask;

  // Smooth with [1 2 1] so a surface straddling two bins is not split, then grow from the peak.
  std::vector<double> smooth(num_bins, 0.0);
  for (int i = 0; i < num_bins; ++i) {
    smooth[i] = 2 * hist[i] + (i > 0 ? hist[i - 1] : 0.0) + (i + 1 < num_bins ? hist[i + 1] : 0.0);
  }
  const int peak =
      static_cast<int>(std::max_element(smooth.begin(), smooth.end()) - smooth.begin());
  const double floor_weight = o.min_bin_fraction * smooth[peak];
  auto grow = [&](int step) {
    int edge = peak, gap = 0;
    for (int i = peak + step; i >= 0 && i < num_bins; i += step) {
      if (hist[i] > floor_weight) {
        edge = i;
        gap = 0;
      } else if (++gap > o.max_gap_bins) {
        break;
      }
    }
    return edge;
  };
  const int lo = grow(-1), hi = grow(+1);
  for (int v = 0; v < roi.height; ++v) {
    const int* b = bin_of.ptr<int>(v);
    uint8_t* m = mask.ptr<uint8_t>(v);
    for (int u = 0; u < roi.width; ++u) m[u] = (b[u] >= lo && b[u] <= hi) ? 255 : 0;
  }

  if (o.morph_kernel_px > 1) {
    const cv::Mat k =
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(o.morph_kernel_px, o.morph_kernel_px));
    cv::morphologyEx(mask, mask, cv::MORPH_OPEN, k);
  }
  if (o.largest_component) {
    cv::Mat labels;
    const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
    if (n > 2) {
      std::vector<double> score(n, 0.0);
      for (int v = 0; v < roi.height; ++v) {
        const int* l = labels.ptr<int>(v);
        const float* w = weight.ptr<float>(v);
        for (int u = 0; u < roi.width; ++u) score[l[u]] += l[u] > 0 ? w[u] : 0.0;
      }
      const int best =
          static_cast<int>(std::max_element(score.begin() + 1, score.end()) - score.begin());
      mask = (labels == best);
    }
  }
  if (o.morph_kernel_px > 1) {
    const cv::Mat k =
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(o.morph_kernel_px, o.morph_kernel_px));
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
