// How well a detection's own pixels fill its box: the depth-support gate of an observation
// (per-observation quality). A dark screen seen at a slant returns no depth; its box
// then holds only the wall around and behind it, and the depth mask takes that wall. Such a mask
// is a ring: it covers the box's middle less than the box as a whole.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace loci::server {

// Shares of the free pixels a label covers, in the middle half of the box (u and v) and in the
// whole box. Free pixels are the label's own and background ones: pixels another detection took
// (a keyboard's box painted over a monitor's, a person cut out) count neither way. 1 where no
// pixel is free.
struct MaskCover {
  double centre = 1;
  double whole = 1;
};

// labels: CV_16SC1, rect inside it.
MaskCover CoverOf(const cv::Mat& labels, const cv::Rect& rect, int16_t label,
                  int16_t background_label);

// A ring-shaped mask: its centre is covered less than min_centre_cover and less than the box as a
// whole. min_centre_cover <= 0: never.
bool IsHollow(const MaskCover& cover, double min_centre_cover);

}  // namespace loci::server
