#include "detection/nanodet_detector.h"

#include <filesystem>

#include "detection/decode.h"
#include "detection/onnx_common.h"

namespace loci::detection {

StatusOr<std::unique_ptr<NanoDetDetector>> NanoDetDetector::Create(const DetectorOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  LOCI_ASSIGN_OR_RETURN(std::vector<std::string> names, LoadClassNamesFor(options));
  LOCI_ASSIGN_OR_RETURN(cv::dnn::Net net, LoadOnnxNet(options.model_path));
  ApplyThreads(options);
  return std::unique_ptr<NanoDetDetector>(
      new NanoDetDetector(options, std::move(net), std::move(names)));
}

NanoDetDetector::NanoDetDetector(DetectorOptions options, cv::dnn::Net net,
                                 std::vector<std::string> names)
    : options_(std::move(options)), net_(std::move(net)), class_names_(std::move(names)) {
  output_names_ = net_.getUnconnectedOutLayersNames();
  name_ = std::filesystem::path(options_.model_path).stem().string();
}

StatusOr<std::vector<Detection2D>> NanoDetDetector::Detect(const cv::Mat& bgr, int64_t /*t_ns*/) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    return absl::InvalidArgumentError("NanoDet: expected a non-empty CV_8UC3 BGR image");
  }
  Letterbox lb;
  const cv::Mat input = LetterboxCentred(bgr, options_.input_size_px, &lb);
  // Per-channel (x - mean) / std in BGR order.
  cv::Mat normalised;
  input.convertTo(normalised, CV_32FC3);
  cv::subtract(normalised, cv::Scalar(103.53, 116.28, 123.675), normalised);
  cv::divide(normalised, cv::Scalar(57.375, 57.12, 58.395), normalised);
  const cv::Mat blob =
      cv::dnn::blobFromImage(normalised, 1.0, cv::Size(), cv::Scalar(), false, false);
  std::vector<cv::Mat> outputs;
  // Outputs may alias the network's buffers: decode before releasing the lock.
  std::lock_guard<std::mutex> lock(mu_);
  {
    try {
      net_.setInput(blob);
      net_.forward(outputs, output_names_);
    } catch (const cv::Exception& e) {
      return absl::InternalError(absl::StrCat("NanoDet forward failed: ", e.what()));
    }
  }
  LOCI_ASSIGN_OR_RETURN(std::vector<Candidate> candidates,
                        DecodeNanodet(outputs, options_.input_size_px, lb, MinThreshold(options_)));
  return FinishDetections(candidates, class_names_, options_, bgr.size());
}

}  // namespace loci::detection
