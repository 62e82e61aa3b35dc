#include "detection/appearance.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "common/detections_io.h"

namespace loci::detection {

cv::Mat HsvHistogram(const cv::Mat& bgr, const cv::Rect2f& box_px, const cv::Mat& mask,
                     const AppearanceOptions& o) {
  if (bgr.empty() || bgr.type() != CV_8UC3) return {};
  const cv::Rect roi = MaskRect(box_px, bgr.cols, bgr.rows);
  if (roi.width <= 0 || roi.height <= 0) return {};
  cv::Mat patch = bgr(roi);
  cv::Mat m = (!mask.empty() && mask.size() == roi.size()) ? mask : cv::Mat();
  const double s =
      std::min(1.0, static_cast<double>(o.max_side_px) / std::max(roi.width, roi.height));
  if (s < 1.0) {
    const cv::Size small(std::max(1, static_cast<int>(roi.width * s)),
                         std::max(1, static_cast<int>(roi.height * s)));
    cv::resize(patch, patch, small, 0, 0, cv::INTER_AREA);
    if (!m.empty()) cv::resize(m, m, small, 0, 0, cv::INTER_NEAREST);
  }
  cv::Mat hsv;
  cv::cvtColor(patch, hsv, cv::COLOR_BGR2HSV);
  if (o.min_saturation > 0) {
    cv::Mat sat_ok;
    cv::extractChannel(hsv, sat_ok, 1);
    sat_ok = sat_ok >= o.min_saturation;
    m = m.empty() ? sat_ok : (m & sat_ok);
  }
  const int channels[] = {0, 1};
  const int sizes[] = {o.hue_bins, o.saturation_bins};
  const float hue_range[] = {0.f, 180.f}, sat_range[] = {0.f, 256.f};
  const float* ranges[] = {hue_range, sat_range};
  cv::Mat hist;
  cv::calcHist(&hsv, 1, channels, m, hist, 2, sizes, ranges);
  const double total = cv::sum(hist)[0];
  if (total <= 0.0) return {};
  hist /= total;
  return hist;
}

double HistogramDistance(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty() || a.size != b.size) return 1.0;
  return std::clamp(cv::compareHist(a, b, cv::HISTCMP_BHATTACHARYYA), 0.0, 1.0);
}

}  // namespace loci::detection
