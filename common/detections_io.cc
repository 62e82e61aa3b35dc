#include "common/detections_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

#include "absl/strings/escaping.h"
#include "common/image_codec.h"
#include "common/time.h"

namespace loci {

float BoxIou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float inter = (a & b).area();
  const float uni = a.area() + b.area() - inter;
  return uni > 0.f && inter > 0.f ? inter / uni : 0.f;
}

cv::Rect MaskRect(const cv::Rect2f& box_px, int image_width, int image_height) {
  const int x0 = static_cast<int>(std::floor(box_px.x));
  const int y0 = static_cast<int>(std::floor(box_px.y));
  const int x1 = static_cast<int>(std::ceil(box_px.x + box_px.width));
  const int y1 = static_cast<int>(std::ceil(box_px.y + box_px.height));
  return cv::Rect(x0, y0, x1 - x0, y1 - y0) & cv::Rect(0, 0, image_width, image_height);
}

std::string DetectionsToJsonLine(const FrameDetections& frame) {
  nlohmann::json j;
  j["t"] = FormatNsAsSeconds(frame.t_ns);
  j["t_ns"] = frame.t_ns;
  j["detections"] = nlohmann::json::array();
  for (const Detection2D& d : frame.detections) {
    nlohmann::json dj = {{"class_id", d.class_id},
                         {"class_name", d.class_name},
                         {"score", d.score},
                         {"box", {d.box_px.x, d.box_px.y, d.box_px.width, d.box_px.height}},
                         {"track_id", d.track_id}};
    if (!d.mask.empty()) {
      auto png = EncodeMaskPng(d.mask);
      if (png.ok()) dj["mask_png_b64"] = absl::Base64Escape(*png);
    }
    j["detections"].push_back(std::move(dj));
  }
  return j.dump();
}

StatusOr<FrameDetections> DetectionsFromJsonLine(const std::string& line) {
  FrameDetections f;
  try {
    const nlohmann::json j = nlohmann::json::parse(line);
    if (j.contains("t_ns")) {
      f.t_ns = j.at("t_ns").get<int64_t>();
    } else {
      LOCI_ASSIGN_OR_RETURN(f.t_ns, ParseSecondsToNs(j.at("t").get<std::string>()));
    }
    for (const auto& dj : j.at("detections")) {
      Detection2D d;
      d.class_id = dj.value("class_id", -1);
      d.class_name = dj.at("class_name").get<std::string>();
      d.score = dj.value("score", 1.0f);
      const auto& b = dj.at("box");
      if (!b.is_array() || b.size() != 4) {
        return absl::InvalidArgumentError("detection box must be [x, y, w, h]");
      }
      d.box_px = cv::Rect2f(b[0].get<float>(), b[1].get<float>(), b[2].get<float>(),
                            b[3].get<float>());
      if (!(d.box_px.width > 0 && d.box_px.height > 0)) {
        return absl::InvalidArgumentError("detection box has no area");
      }
      d.track_id = dj.value("track_id", int64_t{0});
      if (dj.contains("mask_png_b64")) {
        std::string png;
        if (!absl::Base64Unescape(dj.at("mask_png_b64").get<std::string>(), &png)) {
          return absl::InvalidArgumentError("mask_png_b64 is not base64");
        }
        LOCI_ASSIGN_OR_RETURN(d.mask, DecodeMaskPng(png));
      }
      f.detections.push_back(std::move(d));
    }
  } catch (const nlohmann::json::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("detections line: ", e.what()));
  }
  return f;
}

StatusOr<std::vector<FrameDetections>> ReadDetectionsJsonl(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  std::vector<FrameDetections> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    auto f = DetectionsFromJsonLine(line);
    if (!f.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ":", line_no, ": ", f.status().message()));
    }
    out.push_back(std::move(*f));
  }
  std::sort(out.begin(), out.end(),
            [](const FrameDetections& a, const FrameDetections& b) { return a.t_ns < b.t_ns; });
  return out;
}

Status WriteDetectionsJsonl(const std::string& path, const std::vector<FrameDetections>& frames) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError(absl::StrCat("cannot write ", path));
  for (const FrameDetections& f : frames) out << DetectionsToJsonLine(f) << "\n";
  if (!out) return absl::DataLossError(absl::StrCat("short write to ", path));
  return absl::OkStatus();
}

const FrameDetections* FindDetections(const std::vector<FrameDetections>& frames, int64_t t_ns,
                                      int64_t max_dt_ns) {
  return NearestByTime<FrameDetections>(frames, t_ns, max_dt_ns);
}

}  // namespace loci
