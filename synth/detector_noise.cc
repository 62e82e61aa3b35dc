#include "synth/detector_noise.h"

#include <algorithm>
#include <map>
#include <string>
#include <utility>

#include "synth/object_catalog.h"
#include "synth/rng.h"

namespace loci::synth {
namespace {

// Classes a small COCO detector mixes up (same shape from some views).
const std::map<std::string, std::string>& LookAlikes() {
  static const std::map<std::string, std::string> m = {
      {"tv", "laptop"},   {"laptop", "tv"},   {"cup", "bottle"},  {"bottle", "cup"},
      {"chair", "couch"}, {"couch", "chair"}, {"book", "laptop"}, {"keyboard", "laptop"}};
  return m;
}

Detection2D Jittered(const Detection2D& d, const DetectorNoise& n, int w, int h, Rng& rng) {
  Detection2D out = d;
  const cv::Rect2f& b = d.box_px;
  float x0 = b.x + n.box_jitter_rel * b.width * rng.Normal();
  float y0 = b.y + n.box_jitter_rel * b.height * rng.Normal();
  float x1 = b.x + b.width + n.box_jitter_rel * b.width * rng.Normal();
  float y1 = b.y + b.height + n.box_jitter_rel * b.height * rng.Normal();
  x0 = std::clamp(x0, 0.f, w - 2.f), y0 = std::clamp(y0, 0.f, h - 2.f);
  x1 = std::clamp(x1, x0 + 1.f, w - 1.f), y1 = std::clamp(y1, y0 + 1.f, h - 1.f);
  out.box_px = cv::Rect2f(x0, y0, x1 - x0, y1 - y0);
  out.mask = cv::Mat();
  out.score = static_cast<float>(rng.Uniform(n.min_score, n.max_score));
  if (rng.Bernoulli(n.confusion_p)) {
    auto it = LookAlikes().find(d.class_name);
    if (it != LookAlikes().end()) {
      out.class_name = it->second;
      out.class_id = CocoClassId(it->second);
    }
  }
  return out;
}

Detection2D FalseBox(const DetectorNoise& n, int w, int h, Rng& rng) {
  const std::vector<ClassSpec>& classes = CoreClasses();
  const ClassSpec& c = classes[rng.UniformInt(0, static_cast<int>(classes.size()) - 1)];
  Detection2D d;
  d.class_name = c.name;
  d.class_id = c.coco_id;
  d.score = static_cast<float>(rng.Uniform(n.min_score, 0.6));
  const float bw = static_cast<float>(rng.Uniform(30, 160)), bh = static_cast<float>(rng.Uniform(30, 160));
  d.box_px = cv::Rect2f(static_cast<float>(rng.Uniform(0, w - bw)),
                        static_cast<float>(rng.Uniform(0, h - bh)), bw, bh);
  return d;
}

}  // namespace

void ApplyDetectorNoise(const DetectorNoise& noise, uint64_t seed, int width_px, int height_px,
                        std::vector<FrameDetections>* frames) {
  Rng rng(Rng::Mix(seed, 0xDE7EC7));
  std::map<int64_t, int64_t> breaks;  // object id -> breaks so far
  for (FrameDetections& frame : *frames) {
    std::vector<Detection2D> out;
    for (const Detection2D& d : frame.detections) {
      if (rng.Bernoulli(noise.track_break_p)) ++breaks[d.track_id];
      const bool small = std::min(d.box_px.width, d.box_px.height) < noise.small_px;
      if (rng.Bernoulli(small ? noise.small_miss_p : noise.miss_p)) continue;
      Detection2D j = Jittered(d, noise, width_px, height_px, rng);
      j.track_id = d.track_id + 1000 * breaks[d.track_id];
      out.push_back(std::move(j));
    }
    if (rng.Bernoulli(noise.false_boxes_per_frame)) {
      out.push_back(FalseBox(noise, width_px, height_px, rng));
    }
    frame.detections = std::move(out);
  }
}

}  // namespace loci::synth
