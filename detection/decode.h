// Pre- and post-processing of the ONNX detectors: letterboxing, raw-output decoding and
// per-class NMS. Pure functions on cv::Mat so they can be tested on hand-made tensors.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "common/status.h"

namespace loci::detection {

// A decoded box before class filtering, in original-image pixels.
struct Candidate {
  int class_id = -1;
  float score = 0.f;
  cv::Rect2f box_px;  // x, y (top-left), width, height
};

// Maps letterbox pixels to original pixels: p_orig = (p_lb - pad_px) / scale.
struct Letterbox {
  float scale = 1.f;     // letterbox px per original px
  float pad_x_px = 0.f;  // left padding in letterbox px
  float pad_y_px = 0.f;  // top padding in letterbox px
};

// YOLOX convention: resize by r = min(S/H, S/W) (INTER_LINEAR) to (int(W*r), int(H*r)), paste
// at the top-left of an SxS canvas filled with 114. BGR stays BGR.
cv::Mat LetterboxTopLeft(const cv::Mat& bgr, int size_px, Letterbox* lb);
// NanoDet convention: keep-ratio resize (INTER_AREA), centred on an SxS canvas filled with 0.
cv::Mat LetterboxCentred(const cv::Mat& bgr, int size_px, Letterbox* lb);

// Decodes a YOLOX output [1, N, 5 + C] or [N, 5 + C] (float32) for input side `input_size_px`
// with strides 8/16/32: rows [tx, ty, tw, th, obj, cls...] (obj and cls sigmoided),
// cx = (tx + gx) * s, w = exp(tw) * s; score = obj * max cls. Keeps score >= min_score.
// InvalidArgument when N does not match the grid.
StatusOr<std::vector<Candidate>> DecodeYolox(const cv::Mat& output, int input_size_px,
                                             const Letterbox& lb, float min_score);

// Decodes NanoDet-m (GFL head, reg_max 7) outputs: for each stride 8/16/32 one class map [N, C]
// and one box-distribution map [N, 32], rank 2 or 3, in any order (picked by shape, never by
// name). Cell centre (g * s + (s - 1) / 2); distances = softmax-expectation of 8 bins * s.
StatusOr<std::vector<Candidate>> DecodeNanodet(const std::vector<cv::Mat>& outputs,
                                               int input_size_px, const Letterbox& lb,
                                               float min_score);

// Non-maximum suppression inside each class (boxes of different classes never suppress each
// other); result sorted by descending score.
std::vector<Candidate> PerClassNms(const std::vector<Candidate>& candidates, float iou_threshold);

}  // namespace loci::detection
