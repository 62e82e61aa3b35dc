// Ground-truth 2-D detections of a rendered frame: what a perfect instance detector would
// report, derived from the instance-id image.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "common/detections_io.h"
#include "synth/scene.h"

namespace loci::synth {

// One detection per object with at least scene.options.min_visible_px visible pixels: box =
// extent of the visible pixels (whole pixels: x, y of the first column/row, width/height in
// pixels), mask = the visible pixels over MaskRect(box), class_id = COCO-80 index, score 1,
// track_id = object id. Objects of non-COCO classes (the shelf) are skipped unless
// options.detect_non_coco. Sorted by object id.
std::vector<Detection2D> DetectionsFromInstances(const Scene& scene, const cv::Mat& instance_id);

}  // namespace loci::synth
