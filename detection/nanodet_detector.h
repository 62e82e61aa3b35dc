// NanoDet-m (ONNX, OpenCV DNN): centred keep-ratio letterbox with 0 fill, BGR mean/std
// normalisation; GFL decode of six outputs picked by shape (models/nanodet_m/README.txt).
#pragma once

#include <memory>
#include <mutex>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "detection/detector.h"
#include "detection/detector_options.h"

namespace loci::detection {

class NanoDetDetector : public Detector {
 public:
  static StatusOr<std::unique_ptr<NanoDetDetector>> Create(const DetectorOptions& options);

  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat& bgr, int64_t t_ns) override;
  std::string Name() const override { return name_; }

 private:
  NanoDetDetector(DetectorOptions options, cv::dnn::Net net, std::vector<std::string> names);

  DetectorOptions options_;
  std::mutex mu_;  // cv::dnn::Net::forward is not reentrant
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  std::vector<std::string> class_names_;
  std::string name_;
};

}  // namespace loci::detection
