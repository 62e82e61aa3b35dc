// Appearance cue for the tracker: a hue-saturation histogram of the box (optionally only the
// mask pixels), compared with the Bhattacharyya distance. Cheap and lighting-tolerant (value
// is ignored); a stand-in for DeepSORT's learned re-identification feature.
#pragma once

#include <opencv2/core.hpp>

namespace loci::detection {

struct AppearanceOptions {
  int hue_bins = 16;        // over OpenCV's hue range 0-180. Default 16.
  int saturation_bins = 4;  // over 0-255. Default 4.
  int min_saturation = 0;   // pixels below are ignored (grey has no stable hue). Default 0.
  int max_side_px = 64;     // the box is downscaled to at most this side first. Default 64.
};

// Normalised (sum 1) CV_32F histogram of bgr(box) restricted to mask (box-sized, may be
// empty); empty Mat when the box misses the image.
cv::Mat HsvHistogram(const cv::Mat& bgr, const cv::Rect2f& box_px, const cv::Mat& mask,
                     const AppearanceOptions& options);

// Bhattacharyya distance in [0, 1] (0 = identical); 1 when either histogram is empty.
double HistogramDistance(const cv::Mat& a, const cv::Mat& b);

}  // namespace loci::detection
