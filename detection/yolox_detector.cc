#include "detection/yolox_detector.h"

#include <filesystem>

#include "detection/decode.h"
#include "detection/onnx_common.h"

namespace loci::detection {

StatusOr<std::unique_ptr<YoloxDetector>> YoloxDetector::Create(const DetectorOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  LOCI_ASSIGN_OR_RETURN(std::vector<std::string> names, LoadClassNamesFor(options));
  LOCI_ASSIGN_OR_RETURN(cv::dnn::Net net, LoadOnnxNet(options.model_path));
  ApplyThreads(options);
  return std::unique_ptr<YoloxDetector>(
      new YoloxDetector(options, std::move(net), std::move(names)));
}

YoloxDetector::YoloxDetector(DetectorOptions options, cv::dnn::Net net,
                             std::vector<std::string> names)
    : options_(std::move(options)), net_(std::move(net)), class_names_(std::move(names)) {
  name_ = std::filesystem::path(options_.model_path).stem().string();
}

StatusOr<std::vector<Detection2D>> YoloxDetector::Detect(const cv::Mat& bgr, int64_t /*t_ns*/) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    return absl::InvalidArgumentError("YOLOX: expected a non-empty CV_8UC3 BGR image");
  }
  Letterbox lb;
  const cv::Mat input = LetterboxTopLeft(bgr, options_.input_size_px, &lb);
  const cv::Mat blob = cv::dnn::blobFromImage(input, 1.0, cv::Size(), cv::Scalar(), false, false);
  cv::Mat output;
  // Outputs may alias the network's buffers: decode before releasing the lock.
  std::lock_guard<std::mutex> lock(mu_);
  {
    try {
      net_.setInput(blob);
      output = net_.forward();
    } catch (const cv::Exception& e) {
      return absl::InternalError(absl::StrCat("YOLOX forward failed: ", e.what()));
    }
  }
  LOCI_ASSIGN_OR_RETURN(std::vector<Candidate> candidates,
                        DecodeYolox(output, options_.input_size_px, lb, MinThreshold(options_)));
  return FinishDetections(candidates, class_names_, options_, bgr.size());
}

}  // namespace loci::detection
