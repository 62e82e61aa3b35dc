// YOLOX (ONNX, OpenCV DNN): top-left letterbox with 114 fill, BGR, raw 0..255 input; decode
// with strides 8/16/32 and per-class NMS (models/yolox_nano/README.txt).
#pragma once

#include <memory>
#include <mutex>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "detection/detector.h"
#include "detection/detector_options.h"

namespace loci::detection {

class YoloxDetector : public Detector {
 public:
  // Loads the model and class names; errors on a missing or corrupt file.
  static StatusOr<std::unique_ptr<YoloxDetector>> Create(const DetectorOptions& options);

  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat& bgr, int64_t t_ns) override;
  std::string Name() const override { return name_; }

 private:
  YoloxDetector(DetectorOptions options, cv::dnn::Net net, std::vector<std::string> names);

  DetectorOptions options_;
  std::mutex mu_;  // cv::dnn::Net::forward is not reentrant
  cv::dnn::Net net_;
  std::vector<std::string> class_names_;
  std::string name_;
};

}  // namespace loci::detection
