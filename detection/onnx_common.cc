#include "detection/onnx_common.h"

#include <algorithm>
#include <filesystem>

namespace loci::detection {

StatusOr<cv::dnn::Net> LoadOnnxNet(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("model file not found: ", path));
  }
  try {
    cv::dnn::Net net = cv::dnn::readNetFromONNX(path);
    if (net.empty()) return absl::InvalidArgumentError(absl::StrCat("empty ONNX model: ", path));
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    return net;
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot load ONNX model ", path, ": ", e.what()));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot load ONNX model ", path, ": ", e.what()));
  }
}

StatusOr<std::vector<std::string>> LoadClassNamesFor(const DetectorOptions& options) {
  std::string path = options.class_names_path;
  if (path.empty()) {
    path = (std::filesystem::path(options.model_path).parent_path() / "coco80.names").string();
  }
  return ReadClassNames(path);
}

float MinThreshold(const DetectorOptions& options) {
  float t = options.score_threshold;
  for (const auto& [name, v] : options.class_score_thresholds) {
    if (options.Keeps(name)) t = std::min(t, v);
  }
  return t;
}

std::vector<Detection2D> FinishDetections(const std::vector<Candidate>& candidates,
                                          const std::vector<std::string>& class_names,
                                          const DetectorOptions& options, cv::Size image_size) {
  std::vector<Candidate> kept;
  for (const Candidate& c : candidates) {
    if (c.class_id < 0 || c.class_id >= static_cast<int>(class_names.size())) continue;
    const std::string& name = class_names[c.class_id];
    if (!options.Keeps(name) || c.score < options.ThresholdFor(name)) continue;
    kept.push_back(c);
  }
  const cv::Rect2f image(0.f, 0.f, static_cast<float>(image_size.width),
                         static_cast<float>(image_size.height));
  std::vector<Detection2D> out;
  for (const Candidate& c : PerClassNms(kept, options.nms_iou)) {
    const cv::Rect2f box = c.box_px & image;
    if (box.width < 1.f || box.height < 1.f) continue;
    Detection2D d;
    d.class_id = c.class_id;
    d.class_name = class_names[c.class_id];
    d.score = c.score;
    d.box_px = box;
    out.push_back(std::move(d));
  }
  return out;
}

void ApplyThreads(const DetectorOptions& options) {
  if (options.num_threads > 0) cv::setNumThreads(options.num_threads);
}

}  // namespace loci::detection
