#include "detection/depth_mask.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "common/config.h"
#include "detection/background_planes.h"

namespace loci::detection {

// The keys FromYaml reads, per section (CheckKnownKeys warns about any other).
constexpr const char* kMaskKeys[] = {"depth_scale",           "min_depth_m",
                                     "max_depth_m",           "bin_width_rel",
                                     "centre_sigma_rel",      "min_bin_fraction",
                                     "max_gap_bins",          "min_pixels",
                                     "largest_component",     "morph_kernel_px",
                                     "remove_support_plane",  "plane_tolerance_m",
                                     "plane_tolerance_sigma", "max_background_planes",
                                     "min_plane_support",     "min_outside_fraction",
                                     "min_object_fraction",   "max_centre_fraction",
                                     "horizontal_max_deg",    "support_min_rise_m",
                                     "support_classes",       "flat_top_classes",
                                     "flat_top_margin_m",     "bare_support_max_tolerance_m",
                                     "thin_classes"};

StatusOr<MaskOptions> MaskOptions::FromYaml(const YAML::Node& node) {
  MaskOptions o;
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, "mask", kMaskKeys));
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
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_background_planes", &o.max_background_planes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_plane_support", &o.min_plane_support));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_outside_fraction", &o.min_outside_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "min_object_fraction", &o.min_object_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "max_centre_fraction", &o.max_centre_fraction));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "horizontal_max_deg", &o.horizontal_max_deg));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "support_min_rise_m", &o.support_min_rise_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "support_classes", &o.support_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "flat_top_classes", &o.flat_top_classes));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "flat_top_margin_m", &o.flat_top_margin_m));
  LOCI_RETURN_IF_ERROR(
      ReadOptional(node, "bare_support_max_tolerance_m", &o.bare_support_max_tolerance_m));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "thin_classes", &o.thin_classes));
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
  if (!(plane_tolerance_m > 0.f) || !(plane_tolerance_sigma >= 0.f) || max_background_planes < 0 ||
      !(min_plane_support > 0.f && min_plane_support <= 1.f) ||
      !(min_outside_fraction > 0.f && min_outside_fraction <= 1.f) ||
      !(min_object_fraction >= 0.f && min_object_fraction < 1.f) ||
      !(max_centre_fraction > 0.f && max_centre_fraction <= 1.f) ||
      !(horizontal_max_deg >= 0.f && horizontal_max_deg < 90.f) || !(support_min_rise_m >= 0.f) ||
      !(flat_top_margin_m >= 0.f) || !(bare_support_max_tolerance_m >= 0.f)) {
    return absl::InvalidArgumentError("mask: invalid background-plane parameter");
  }
  return absl::OkStatus();
}

bool MaskOptions::IsSupportClass(const std::string& class_name) const {
  return std::find(support_classes.begin(), support_classes.end(), class_name) !=
         support_classes.end();
}

bool MaskOptions::IsFlatTopClass(const std::string& class_name) const {
  return IsSupportClass(class_name) && std::find(flat_top_classes.begin(), flat_top_classes.end(),
                                                 class_name) != flat_top_classes.end();
}

bool MaskOptions::IsThinClass(const std::string& class_name) const {
  return std::find(thin_classes.begin(), thin_classes.end(), class_name) != thin_classes.end();
}

namespace {

// Bin marks in bin_of: no valid depth, or on a background plane.
constexpr int kNoDepth = -1;
constexpr int kBackground = -2;

// The box's depth in metres (CV_32F); 0 = no usable reading.
cv::Mat RoiDepthM(const cv::Mat& depth, const cv::Rect& roi, const MaskOptions& o) {
  cv::Mat depth_m;
  if (depth.depth() == CV_16U) {
    depth(roi).convertTo(depth_m, CV_32F, 1.0 / o.depth_scale);
  } else {
    depth_m = depth(roi).clone();
    cv::patchNaNs(depth_m, 0.0);
  }
  depth_m.setTo(0.f, (depth_m < o.min_depth_m) | (depth_m > o.max_depth_m));
  return depth_m;
}

// Gaussian weight of each roi pixel around the box centre (sigma centre_sigma_rel of the box).
cv::Mat CentreWeights(const cv::Rect2f& box_px, const cv::Rect& roi, const MaskOptions& o) {
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
  cv::Mat weight(roi.size(), CV_32F);
  for (int v = 0; v < roi.height; ++v) {
    const double dy = (v + 0.5 - cy) / sy;
    const float wy = static_cast<float>(std::exp(-0.5 * dy * dy));
    float* w = weight.ptr<float>(v);
    for (int u = 0; u < roi.width; ++u) w[u] = wx[u] * wy;
  }
  return weight;
}

// Log-depth bins of the box: each pixel's bin (kNoDepth, kBackground) and the centre-weighted
// histogram of the bins.
struct DepthBins {
  cv::Mat bin_of;  // CV_32S
  std::vector<double> hist;
  int valid = 0;  // pixels with a usable reading, background ones included
};

DepthBins BinDepths(const cv::Mat& depth_m, const cv::Mat& background, const cv::Mat& weight,
                    const MaskOptions& o) {
  const double log_min = std::log(o.min_depth_m);
  const double log_step = std::log1p(o.bin_width_rel);
  const int num_bins =
      static_cast<int>(std::ceil((std::log(o.max_depth_m) - log_min) / log_step)) + 1;
  DepthBins out;
  out.hist.assign(num_bins, 0.0);
  out.bin_of = cv::Mat(depth_m.size(), CV_32S, cv::Scalar(kNoDepth));
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* d = depth_m.ptr<float>(v);
    int* b = out.bin_of.ptr<int>(v);
    const float* w = weight.ptr<float>(v);
    const uint8_t* bg = background.ptr<uint8_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      if (!(d[u] >= o.min_depth_m && d[u] <= o.max_depth_m)) continue;
      ++out.valid;
      if (bg[u]) {
        b[u] = kBackground;
        continue;
      }
      b[u] = std::clamp(static_cast<int>((std::log(d[u]) - log_min) / log_step), 0, num_bins - 1);
      out.hist[b[u]] += w[u];
    }
  }
  return out;
}

struct DepthCluster {
  int lo, hi;  // bins
  double weight;
};

// Depth clusters: runs of bins above a floor (min_bin_fraction of the [1 2 1]-smoothed peak, so a
// surface straddling two bins is not split), bridging at most max_gap_bins weaker ones; the three
// heaviest.
std::vector<DepthCluster> DepthClusters(const std::vector<double>& hist, const MaskOptions& o) {
  const int num_bins = static_cast<int>(hist.size());
  std::vector<double> smooth(num_bins, 0.0);
  for (int i = 0; i < num_bins; ++i) {
    smooth[i] = 2 * hist[i] + (i > 0 ? hist[i - 1] : 0.0) + (i + 1 < num_bins ? hist[i + 1] : 0.0);
  }
  const double floor_weight = o.min_bin_fraction * *std::max_element(smooth.begin(), smooth.end());
  std::vector<DepthCluster> clusters;
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
            [](const DepthCluster& a, const DepthCluster& b) { return a.weight > b.weight; });
  if (clusters.size() > 3) clusters.resize(3);
  return clusters;
}

// The pixels of one cluster, opened with the kernel, as their best connected component (or all
// of them, without largest_component); *score: centre weight times the share of the box the
// result spans. Empty when nothing is left.
cv::Mat ClusterMask(const DepthCluster& c, const cv::Mat& bin_of, const cv::Mat& weight, int kernel,
                    const MaskOptions& o, double* score_out) {
  cv::Mat m(bin_of.size(), CV_8UC1);
  for (int v = 0; v < bin_of.rows; ++v) {
    const int* b = bin_of.ptr<int>(v);
    uint8_t* row = m.ptr<uint8_t>(v);
    for (int u = 0; u < bin_of.cols; ++u) row[u] = (b[u] >= c.lo && b[u] <= c.hi) ? 255 : 0;
  }
  if (kernel > 1) {
    cv::morphologyEx(m, m, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kernel, kernel)));
  }
  cv::Mat labels;
  const int n = cv::connectedComponents(m, labels, 8, CV_32S);
  if (n < 2) return {};
  std::vector<double> score(n, 0.0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const float* w = weight.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u) score[l[u]] += l[u] > 0 ? w[u] : 0.0;
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
  const double span =
      (static_cast<double>(extent.width) / m.cols) * (static_cast<double>(extent.height) / m.rows);
  *score_out = score[1] * span;
  return m;
}

// Close fills pinholes of missing depth inside the object, never pixels of other depth.
void FillDepthHoles(const cv::Mat& bin_of, int kernel, cv::Mat* mask) {
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kernel, kernel));
  cv::Mat closed;
  cv::morphologyEx(*mask, closed, cv::MORPH_CLOSE, k);
  for (int v = 0; v < bin_of.rows; ++v) {
    const int* b = bin_of.ptr<int>(v);
    const uint8_t* c = closed.ptr<uint8_t>(v);
    uint8_t* m = mask->ptr<uint8_t>(v);
    for (int u = 0; u < bin_of.cols; ++u) {
      if (c[u] && b[u] == kNoDepth) m[u] = 255;
    }
  }
}

}  // namespace

cv::Mat SegmentObjectDepth(const cv::Mat& depth, const cv::Rect2f& box_px, const MaskOptions& o,
                           const MaskContext& context) {
  if (depth.empty() || depth.channels() != 1 ||
      (depth.depth() != CV_16U && depth.depth() != CV_32F)) {
    return {};
  }
  const cv::Rect roi = MaskRect(box_px, depth.cols, depth.rows);
  if (roi.width <= 0 || roi.height <= 0) return {};
  const cv::Mat depth_m = RoiDepthM(depth, roi, o);
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8UC1);
  BackgroundPlanes planes;
  if (o.remove_support_plane) planes = BackgroundPlaneMask(depth, roi, depth_m, o, context);
  if (planes.bare_support) return mask;
  const cv::Mat background =
      planes.mask.empty() ? cv::Mat(cv::Mat::zeros(roi.size(), CV_8UC1)) : planes.mask;
  const cv::Mat weight = CentreWeights(box_px, roi, o);
  const DepthBins bins = BinDepths(depth_m, background, weight, o);
  if (bins.valid < o.min_pixels) return mask;

  // Small boxes (thin objects) lose too much to morphology.
  const int kernel =
      std::min(roi.width, roi.height) >= 8 * o.morph_kernel_px ? o.morph_kernel_px : 1;
  // Each candidate cluster -> its best connected component, scored by centre weight times how
  // much of the box it spans (a detector's box is tight on the object's visible pixels, while
  // an occluder in front or a patch of background rarely spans it).
  double best_score = -1.0;
  for (const DepthCluster& c : DepthClusters(bins.hist, o)) {
    double score = 0;
    cv::Mat m = ClusterMask(c, bins.bin_of, weight, kernel, o, &score);
    if (!m.empty() && score > best_score) {
      best_score = score;
      mask = m;
    }
  }
  if (kernel > 1) FillDepthHoles(bins.bin_of, kernel, &mask);
  return mask;
}

void AttachDepthMasks(const cv::Mat& depth, std::vector<Detection2D>* detections,
                      const MaskOptions& options, const std::optional<PinholeCamera>& camera,
                      const std::optional<Eigen::Vector3d>& gravity_cam) {
  MaskContext context{"", camera, gravity_cam};
  for (Detection2D& d : *detections) {
    if (!d.mask.empty()) continue;  // an external detector's own mask wins
    context.class_name = d.class_name;
    cv::Mat m = SegmentObjectDepth(depth, d.box_px, options, context);
    if (!m.empty() && cv::countNonZero(m) > 0) d.mask = m;
  }
}

}  // namespace loci::detection
