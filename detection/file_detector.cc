#include "detection/file_detector.h"

#include <algorithm>

namespace loci::detection {

StatusOr<std::unique_ptr<FileDetector>> FileDetector::Create(const DetectorOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  if (options.detections_path.empty()) {
    return absl::InvalidArgumentError("file detector: detections_file is not set");
  }
  LOCI_ASSIGN_OR_RETURN(std::vector<FrameDetections> frames,
                        ReadDetectionsJsonl(options.detections_path));
  std::sort(frames.begin(), frames.end(),
            [](const FrameDetections& a, const FrameDetections& b) { return a.t_ns < b.t_ns; });
  return std::unique_ptr<FileDetector>(new FileDetector(options, std::move(frames)));
}

FileDetector::FileDetector(DetectorOptions options, std::vector<FrameDetections> frames)
    : options_(std::move(options)), frames_(std::move(frames)) {}

StatusOr<std::vector<Detection2D>> FileDetector::Detect(const cv::Mat& bgr, int64_t t_ns) {
  std::vector<Detection2D> out;
  const FrameDetections* frame = FindDetections(frames_, t_ns, options_.max_dt_ns);
  if (frame == nullptr) return out;
  for (const Detection2D& d : frame->detections) {
    if (!options_.Keeps(d.class_name) || d.score < options_.ThresholdFor(d.class_name)) continue;
    Detection2D kept = d;
    if (!bgr.empty()) {
      const cv::Rect2f image(0.f, 0.f, static_cast<float>(bgr.cols), static_cast<float>(bgr.rows));
      kept.box_px = d.box_px & image;
      if (kept.box_px.width < 1.f || kept.box_px.height < 1.f) continue;
      // A stored mask covers MaskRect of the stored box; drop it if clipping changed that.
      if (!kept.mask.empty() &&
          kept.mask.size() != MaskRect(kept.box_px, bgr.cols, bgr.rows).size()) {
        kept.mask.release();
      }
    }
    out.push_back(std::move(kept));
  }
  return out;
}

}  // namespace loci::detection
