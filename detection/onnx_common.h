// Helpers shared by the ONNX detectors: safe model loading and the candidate -> Detection2D
// step (class filter, per-class thresholds, per-class NMS, clipping).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "common/detections_io.h"
#include "common/status.h"
#include "detection/decode.h"
#include "detection/detector_options.h"

namespace loci::detection {

// Loads an ONNX file with OpenCV DNN (CPU backend). NotFound when missing, InvalidArgument
// (with OpenCV's message) when the file does not parse; never throws.
StatusOr<cv::dnn::Net> LoadOnnxNet(const std::string& path);

// Class names for `options` (class_names_path, or coco80.names beside the model).
StatusOr<std::vector<std::string>> LoadClassNamesFor(const DetectorOptions& options);

// Keeps candidates whose class passes the filter and its threshold, runs per-class NMS, clips
// boxes to the image (image_size) and drops empty ones.
std::vector<Detection2D> FinishDetections(const std::vector<Candidate>& candidates,
                                          const std::vector<std::string>& class_names,
                                          const DetectorOptions& options, cv::Size image_size);

// Lowest score any kept class can pass with (decode pre-filter).
float MinThreshold(const DetectorOptions& options);

// Applies options.num_threads (process-wide OpenCV setting) when > 0.
void ApplyThreads(const DetectorOptions& options);

}  // namespace loci::detection
