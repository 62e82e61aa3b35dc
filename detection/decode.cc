#include "detection/decode.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

namespace loci::detection {
namespace {

constexpr std::array<int, 3> kStrides = {8, 16, 32};

// Rows x cols view of a rank-2 or rank-3 ([1, N, C]) float tensor; empty on other shapes.
cv::Mat As2d(const cv::Mat& t) {
  if (t.type() != CV_32F || t.empty()) return {};
  if (t.dims == 2) return t.isContinuous() ? t : t.clone();
  if (t.dims == 3 && t.size[0] == 1) {
    cv::Mat c = t.isContinuous() ? t : t.clone();
    return cv::Mat(c.size[1], c.size[2], CV_32F, c.ptr<float>());
  }
  return {};
}

cv::Rect2f ToOriginal(float x1, float y1, float x2, float y2, const Letterbox& lb) {
  const float s = lb.scale > 0.f ? lb.scale : 1.f;
  const float ox1 = (x1 - lb.pad_x_px) / s, oy1 = (y1 - lb.pad_y_px) / s;
  const float ox2 = (x2 - lb.pad_x_px) / s, oy2 = (y2 - lb.pad_y_px) / s;
  return {ox1, oy1, ox2 - ox1, oy2 - oy1};
}

}  // namespace

cv::Mat LetterboxTopLeft(const cv::Mat& bgr, int size_px, Letterbox* lb) {
  const double r =
      std::min(static_cast<double>(size_px) / bgr.rows, static_cast<double>(size_px) / bgr.cols);
  const int w = std::max(1, static_cast<int>(bgr.cols * r));
  const int h = std::max(1, static_cast<int>(bgr.rows * r));
  cv::Mat canvas(size_px, size_px, CV_8UC3, cv::Scalar(114, 114, 114));
  cv::Mat resized;
  cv::resize(bgr, resized, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
  resized.copyTo(canvas(cv::Rect(0, 0, w, h)));
  *lb = {static_cast<float>(r), 0.f, 0.f};
  return canvas;
}

cv::Mat LetterboxCentred(const cv::Mat& bgr, int size_px, Letterbox* lb) {
  const double r =
      std::min(static_cast<double>(size_px) / bgr.rows, static_cast<double>(size_px) / bgr.cols);
  const int w = std::max(1, static_cast<int>(bgr.cols * r));
  const int h = std::max(1, static_cast<int>(bgr.rows * r));
  const int left = (size_px - w) / 2, top = (size_px - h) / 2;
  cv::Mat canvas(size_px, size_px, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat resized;
  cv::resize(bgr, resized, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  resized.copyTo(canvas(cv::Rect(left, top, w, h)));
  // The scale is taken per axis in NanoDet's reference code; with keep-ratio they are equal up
  // to rounding, so the mean is used.
  const float scale = 0.5f * (static_cast<float>(w) / bgr.cols + static_cast<float>(h) / bgr.rows);
  *lb = {scale, static_cast<float>(left), static_cast<float>(top)};
  return canvas;
}

StatusOr<std::vector<Candidate>> DecodeYolox(const cv::Mat& output, int input_size_px,
                                             const Letterbox& lb, float min_score) {
  const cv::Mat rows = As2d(output);
  if (rows.empty() || rows.cols < 6) {
    return absl::InvalidArgumentError("YOLOX output: expected float [1, N, 5 + C]");
  }
  int expected = 0;
  for (int s : kStrides) expected += (input_size_px / s) * (input_size_px / s);
  if (rows.rows != expected) {
    return absl::InvalidArgumentError(absl::StrCat("YOLOX output has ", rows.rows, " rows, input ",
                                                   input_size_px, " needs ", expected));
  }
  const int num_classes = rows.cols - 5;
  std::vector<Candidate> out;
  int row = 0;
  for (int stride : kStrides) {
    const int g = input_size_px / stride;
    for (int gy = 0; gy < g; ++gy) {
      for (int gx = 0; gx < g; ++gx, ++row) {
        const float* p = rows.ptr<float>(row);
        const float obj = p[4];
        if (!(obj >= min_score)) continue;  // score = obj * cls <= obj; also drops NaN
        const float* cls = p + 5;
        const int c = static_cast<int>(std::max_element(cls, cls + num_classes) - cls);
        const float score = obj * cls[c];
        if (!(score >= min_score)) continue;
        const float cx = (p[0] + gx) * stride, cy = (p[1] + gy) * stride;
        const float w = std::exp(p[2]) * stride, h = std::exp(p[3]) * stride;
        if (!std::isfinite(w) || !std::isfinite(h)) continue;
        out.push_back({c, score, ToOriginal(cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2, lb)});
      }
    }
  }
  return out;
}

StatusOr<std::vector<Candidate>> DecodeNanodet(const std::vector<cv::Mat>& outputs,
                                               int input_size_px, const Letterbox& lb,
                                               float min_score) {
  constexpr int kBins = 8;  // reg_max 7 -> 8 bins per side, 32 values per cell
  std::map<int, cv::Mat> cls_by_n, box_by_n;
  int num_classes = 0;
  for (const cv::Mat& t : outputs) {
    cv::Mat m = As2d(t);
    if (m.empty()) return absl::InvalidArgumentError("NanoDet output: unexpected tensor shape");
    if (m.cols == 4 * kBins) {
      box_by_n[m.rows] = m;
    } else {
      cls_by_n[m.rows] = m;
      num_classes = m.cols;
    }
  }
  std::vector<Candidate> out;
  for (int stride : kStrides) {
    const int g = input_size_px / stride;
    const int n = g * g;
    if (!cls_by_n.count(n) || !box_by_n.count(n)) {
      return absl::InvalidArgumentError(absl::StrCat("NanoDet output: no class/box maps with ", n,
                                                     " cells for stride ", stride, " at input ",
                                                     input_size_px));
    }
    const cv::Mat& cls = cls_by_n[n];
    const cv::Mat& box = box_by_n[n];
    for (int i = 0; i < n; ++i) {
      const float* pc = cls.ptr<float>(i);
      const int c = static_cast<int>(std::max_element(pc, pc + num_classes) - pc);
      if (!(pc[c] >= min_score)) continue;  // also drops NaN
      const float* pb = box.ptr<float>(i);
      std::array<float, 4> d{};  // left, top, right, bottom distances in bins
      for (int k = 0; k < 4; ++k) {
        const float* bins = pb + k * kBins;
        const float mx = *std::max_element(bins, bins + kBins);
        float sum = 0.f, expect = 0.f;
        for (int j = 0; j < kBins; ++j) {
          const float e = std::exp(bins[j] - mx);
          sum += e;
          expect += e * j;
        }
        d[k] = expect / sum * stride;
      }
      const float cx = (i % g) * stride + (stride - 1) * 0.5f;
      const float cy = (i / g) * stride + (stride - 1) * 0.5f;
      out.push_back({c, pc[c], ToOriginal(cx - d[0], cy - d[1], cx + d[2], cy + d[3], lb)});
    }
  }
  return out;
}

std::vector<Candidate> PerClassNms(const std::vector<Candidate>& candidates, float iou_threshold) {
  // OpenCV 4.6 has no NMSBoxesBatched: run NMSBoxes once per class.
  std::map<int, std::vector<int>> by_class;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    by_class[candidates[i].class_id].push_back(i);
  }
  std::vector<Candidate> kept;
  for (const auto& [cls, idx] : by_class) {
    std::vector<cv::Rect2d> boxes;
    std::vector<float> scores;
    for (int i : idx) {
      boxes.emplace_back(candidates[i].box_px);
      scores.push_back(candidates[i].score);
    }
    std::vector<int> keep;
    cv::dnn::NMSBoxes(boxes, scores, 0.f, iou_threshold, keep);
    for (int k : keep) kept.push_back(candidates[idx[k]]);
  }
  std::sort(kept.begin(), kept.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  return kept;
}

}  // namespace loci::detection
