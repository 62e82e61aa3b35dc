// 2-D detections of one image and their JSON-lines file format (docs/formats.md), shared by the
// detector, the synthetic scene writer, the tracking client and the server.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/status.h"

namespace loci {

struct Detection2D {
  int class_id = -1;           // index in the detector's class list (COCO-80), -1 unknown
  std::string class_name;      // e.g. "cup"
  float score = 0.f;           // [0, 1]
  cv::Rect2f box_px;           // x, y (top-left), width, height in pixels
  // Optional instance mask, CV_8UC1, non-zero = object, covering box_px rounded to whole pixels
  // (cv::Rect(box_px) clipped to the image); empty = no mask.
  cv::Mat mask;
  int64_t track_id = 0;        // 0 = untracked
};

// Intersection over union of two boxes; 0 when either is empty.
float BoxIou(const cv::Rect2f& a, const cv::Rect2f& b);

struct FrameDetections {
  int64_t t_ns = 0;            // stamp of the RGB image
  std::vector<Detection2D> detections;
};

// Whole-pixel rectangle a detection's mask covers: the box rounded outwards, clipped to the image.
cv::Rect MaskRect(const cv::Rect2f& box_px, int image_width, int image_height);

// One line per image: {"t": "1305031229.528748", "t_ns": ..., "detections": [{"class_id": 41,
// "class_name": "cup", "score": 0.9, "box": [x, y, w, h], "track_id": 3,
// "mask_png_b64": "..."}]}. Masks are optional.
StatusOr<std::vector<FrameDetections>> ReadDetectionsJsonl(const std::string& path);
Status WriteDetectionsJsonl(const std::string& path, const std::vector<FrameDetections>& frames);
std::string DetectionsToJsonLine(const FrameDetections& frame);
StatusOr<FrameDetections> DetectionsFromJsonLine(const std::string& line);

// Detections of the frame whose stamp is nearest t_ns within max_dt_ns (frames sorted by t_ns);
// nullptr when none.
const FrameDetections* FindDetections(const std::vector<FrameDetections>& frames, int64_t t_ns,
                                      int64_t max_dt_ns = 20'000'000);

}  // namespace loci
