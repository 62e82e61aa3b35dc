// Procedural surface textures of the synthetic scenes. Each surface gets a deterministic image
// rich in corners (rectangles, print-like text, checkers, blobs) so ORB finds features to track,
// and each object gets its own colours so appearance can tell instances apart.
#pragma once

#include <cmath>
#include <opencv2/core.hpp>

#include "synth/rng.h"

namespace loci::synth {

// A texture image laid on a surface: texel (i, j) covers the square [j, j+1) x [i, i+1) times
// texel_m in the surface's (u, v) coordinates (metres). The image repeats beyond its size.
struct Texture {
  cv::Mat bgr;             // CV_8UC3
  double texel_m = 0.005;  // size of one texel on the surface, metres
};

enum class TextureStyle {
  kFloor,    // wooden planks with rugs and scattered items
  kWall,     // painted wall with posters, notes and frames
  kCeiling,  // acoustic tiles
  kWood,     // furniture: grain, boards, knots
  kPrint,    // object surface: coloured print with labels, shapes and checkers
};

// Makes a width_px x height_px texture of the given style around the base colour (BGR).
Texture MakeTexture(TextureStyle style, const cv::Vec3b& base_bgr, int width_px, int height_px,
                    double texel_m, Rng& rng);

// A saturated colour of hue `hue_deg` (BGR), value in [0, 1] scales brightness.
cv::Vec3b HueColor(double hue_deg, double saturation, double value);

// Bilinear lookup at surface coordinates (u_m, v_m), wrapping around; BGR in [0, 255].
inline cv::Vec3f SampleTexture(const Texture& tex, double u_m, double v_m) {
  const int w = tex.bgr.cols, h = tex.bgr.rows;
  const double x = u_m / tex.texel_m - 0.5, y = v_m / tex.texel_m - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const float ax = static_cast<float>(x - fx), ay = static_cast<float>(y - fy);
  int x0 = static_cast<int>(fx) % w, y0 = static_cast<int>(fy) % h;
  if (x0 < 0) x0 += w;
  if (y0 < 0) y0 += h;
  const int x1 = x0 + 1 == w ? 0 : x0 + 1, y1 = y0 + 1 == h ? 0 : y0 + 1;
  const cv::Vec3b* r0 = tex.bgr.ptr<cv::Vec3b>(y0);
  const cv::Vec3b* r1 = tex.bgr.ptr<cv::Vec3b>(y1);
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) {
    const float top = r0[x0][c] + ax * (r0[x1][c] - r0[x0][c]);
    const float bot = r1[x0][c] + ax * (r1[x1][c] - r1[x0][c]);
    out[c] = top + ay * (bot - top);
  }
  return out;
}

}  // namespace loci::synth
