#include "synth/annotate.h"

#include <algorithm>
#include <map>

namespace loci::synth {

std::vector<Detection2D> DetectionsFromInstances(const Scene& scene, const cv::Mat& instance_id) {
  struct Extent {
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
    int count = 0;
  };
  std::map<int32_t, Extent> extents;
  for (int y = 0; y < instance_id.rows; ++y) {
    const int32_t* row = instance_id.ptr<int32_t>(y);
    for (int x = 0; x < instance_id.cols; ++x) {
      if (row[x] <= 0) continue;
      Extent& e = extents[row[x]];
      e.x0 = std::min(e.x0, x), e.x1 = std::max(e.x1, x);
      e.y0 = std::min(e.y0, y), e.y1 = std::max(e.y1, y);
      ++e.count;
    }
  }
  std::vector<Detection2D> out;
  for (const SceneObject& obj : scene.objects) {
    auto it = extents.find(static_cast<int32_t>(obj.id));
    if (it == extents.end() || it->second.count < scene.options.min_visible_px) continue;
    if (obj.coco_class_id < 0 && !scene.options.detect_non_coco) continue;
    const Extent& e = it->second;
    Detection2D d;
    d.class_id = obj.coco_class_id;
    d.class_name = obj.class_name;
    d.score = 1.f;
    d.box_px = cv::Rect2f(static_cast<float>(e.x0), static_cast<float>(e.y0),
                          static_cast<float>(e.x1 - e.x0 + 1), static_cast<float>(e.y1 - e.y0 + 1));
    const cv::Rect r = MaskRect(d.box_px, instance_id.cols, instance_id.rows);
    cv::Mat mask = instance_id(r) == static_cast<int32_t>(obj.id);  // CV_8UC1, 255 = object
    d.mask = mask;
    d.track_id = obj.id;
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace loci::synth
