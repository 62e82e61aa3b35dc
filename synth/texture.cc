#include "synth/texture.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <string>

namespace loci::synth {
namespace {

cv::Scalar Jitter(const cv::Vec3b& base, double amount, Rng& rng) {
  cv::Scalar s;
  const double k = rng.Uniform(1.0 - amount, 1.0 + amount);
  for (int c = 0; c < 3; ++c) s[c] = std::clamp(base[c] * k + rng.Uniform(-20, 20), 0.0, 255.0);
  return s;
}

// A colour far from `base` in brightness so edges against it are strong corners for FAST.
cv::Scalar Contrast(const cv::Vec3b& base, Rng& rng) {
  const double lum = 0.114 * base[0] + 0.587 * base[1] + 0.299 * base[2];
  const cv::Vec3b c = HueColor(rng.Uniform(0, 360), rng.Uniform(0.3, 1.0),
                               lum > 128 ? rng.Uniform(0.05, 0.35) : rng.Uniform(0.75, 1.0));
  return cv::Scalar(c[0], c[1], c[2]);
}

cv::Point RandPoint(const cv::Mat& img, Rng& rng) {
  return {rng.UniformInt(0, img.cols - 1), rng.UniformInt(0, img.rows - 1)};
}

std::string RandomWord(Rng& rng) {
  static const char kChars[] = "ABCDEFGHJKLMNPQRSTUVWXYZ0123456789";
  std::string s(rng.UniformInt(2, 7), ' ');
  for (char& c : s) c = kChars[rng.UniformInt(0, sizeof(kChars) - 2)];
  return s;
}

// Text lines in the fonts OpenCV ships: print-like patterns full of corners.
void DrawText(cv::Mat& img, const cv::Scalar& color, double scale_px, Rng& rng) {
  const int font = rng.Bernoulli(0.5) ? cv::FONT_HERSHEY_SIMPLEX : cv::FONT_HERSHEY_DUPLEX;
  const double scale = std::max(0.3, scale_px / 22.0);
  const int thickness = std::max(1, static_cast<int>(scale * rng.Uniform(1.0, 2.5)));
  cv::putText(img, RandomWord(rng), RandPoint(img, rng), font, scale, color, thickness,
              cv::LINE_AA);
}

void DrawChecker(cv::Mat& img, cv::Rect r, int cell_px, const cv::Scalar& a, const cv::Scalar& b) {
  r &= cv::Rect(0, 0, img.cols, img.rows);
  cell_px = std::max(cell_px, 2);
  for (int y = r.y; y < r.y + r.height; y += cell_px) {
    for (int x = r.x; x < r.x + r.width; x += cell_px) {
      const bool odd = (((x - r.x) / cell_px) + ((y - r.y) / cell_px)) % 2;
      cv::rectangle(img, cv::Rect(x, y, cell_px, cell_px) & r, odd ? a : b, cv::FILLED);
    }
  }
}

cv::Rect RandRect(const cv::Mat& img, int min_px, int max_px, Rng& rng) {
  const int w = rng.UniformInt(min_px, max_px), h = rng.UniformInt(min_px, max_px);
  return {rng.UniformInt(-w / 2, img.cols - w / 2), rng.UniformInt(-h / 2, img.rows - h / 2), w, h};
}

// Print: a coloured label with shapes, text and checker patches (one per object).
void DrawPrint(cv::Mat& img, const cv::Vec3b& base, Rng& rng) {
  const int s = std::min(img.cols, img.rows);
  for (int i = 0; i < 25; ++i) {
    cv::rectangle(img, RandRect(img, s / 20, s / 4, rng),
                  rng.Bernoulli(0.5) ? Jitter(base, 0.5, rng) : Contrast(base, rng), cv::FILLED);
  }
  for (int i = 0; i < 6; ++i) {
    DrawChecker(img, RandRect(img, s / 10, s / 4, rng), rng.UniformInt(s / 60 + 2, s / 20 + 3),
                Contrast(base, rng), Jitter(base, 0.3, rng));
  }
  for (int i = 0; i < 10; ++i) {
    cv::circle(img, RandPoint(img, rng), rng.UniformInt(s / 40 + 2, s / 10 + 3),
               Contrast(base, rng), rng.Bernoulli(0.5) ? cv::FILLED : 2, cv::LINE_AA);
  }
  for (int i = 0; i < 18; ++i)
    DrawText(img, Contrast(base, rng), rng.Uniform(s / 25.0, s / 8.0), rng);
}

void DrawPlanks(cv::Mat& img, const cv::Vec3b& base, int plank_px, Rng& rng) {
  for (int y = 0; y < img.rows; y += plank_px) {
    for (int x = -rng.UniformInt(0, 6 * plank_px); x < img.cols;) {
      const int len = rng.UniformInt(4 * plank_px, 10 * plank_px);
      cv::rectangle(img, cv::Rect(x, y, len, plank_px), Jitter(base, 0.25, rng), cv::FILLED);
      for (int g = 0; g < 4; ++g) {  // grain
        const int gy = y + rng.UniformInt(1, plank_px - 2);
        cv::line(img, {x, gy}, {x + len, gy + rng.UniformInt(-2, 2)}, Jitter(base, 0.4, rng), 1);
      }
      cv::rectangle(img, cv::Rect(x, y, len, plank_px), cv::Scalar(30, 40, 50), 1);
      x += len;
    }
  }
}

}  // namespace

cv::Vec3b HueColor(double hue_deg, double saturation, double value) {
  cv::Mat hsv(
      1, 1, CV_8UC3,
      cv::Scalar(std::fmod(std::max(hue_deg, 0.0), 360.0) / 2.0,
                 std::clamp(saturation, 0.0, 1.0) * 255, std::clamp(value, 0.0, 1.0) * 255));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr.at<cv::Vec3b>(0, 0);
}

Texture MakeTexture(TextureStyle style, const cv::Vec3b& base_bgr, int width_px, int height_px,
                    double texel_m, Rng& rng) {
  Texture tex;
  tex.texel_m = texel_m;
  cv::Mat& img = tex.bgr;
  img = cv::Mat(std::max(height_px, 8), std::max(width_px, 8), CV_8UC3,
                cv::Scalar(base_bgr[0], base_bgr[1], base_bgr[2]));
  const int m = static_cast<int>(0.1 / texel_m);  // pixels per 10 cm
  switch (style) {
    case TextureStyle::kFloor: {
      DrawPlanks(img, base_bgr, std::max(4, static_cast<int>(1.5 * m)), rng);
      const int area = img.cols * img.rows / (m * m);  // in 1 dm^2
      for (int i = 0; i < 2; ++i) {                    // rugs
        const cv::Rect r = RandRect(img, 8 * m, 16 * m, rng);
        DrawChecker(img, r, rng.UniformInt(m / 2, m), Contrast(base_bgr, rng),
                    Jitter(HueColor(rng.Uniform(0, 360), 0.6, 0.6), 0.2, rng));
      }
      for (int i = 0; i < area / 25; ++i) {  // papers, boxes, stains
        cv::rectangle(img, RandRect(img, m / 2, 2 * m, rng), Contrast(base_bgr, rng), cv::FILLED);
      }
      for (int i = 0; i < area / 60; ++i) DrawText(img, Contrast(base_bgr, rng), 0.5 * m, rng);
      break;
    }
    case TextureStyle::kWall: {
      const int area = img.cols * img.rows / (m * m);
      for (int i = 0; i < area / 40; ++i) {  // posters, each a small print
        const cv::Rect r = RandRect(img, 3 * m, 9 * m, rng) & cv::Rect(0, 0, img.cols, img.rows);
        if (r.area() <= 0) continue;
        cv::Mat roi = img(r);
        const cv::Vec3b poster =
            HueColor(rng.Uniform(0, 360), rng.Uniform(0.3, 0.9), rng.Uniform(0.4, 1.0));
        roi.setTo(cv::Scalar(poster[0], poster[1], poster[2]));
        DrawPrint(roi, poster, rng);
        cv::rectangle(img, r, cv::Scalar(20, 20, 20), std::max(2, m / 8));
      }
      for (int i = 0; i < area / 15; ++i) {  // notes, switches, marks
        cv::rectangle(img, RandRect(img, m / 3, m, rng), Contrast(base_bgr, rng), cv::FILLED);
      }
      for (int i = 0; i < area / 30; ++i) DrawText(img, Contrast(base_bgr, rng), 0.6 * m, rng);
      break;
    }
    case TextureStyle::kCeiling: {
      const int tile = 6 * m;
      for (int i = 0; i < img.cols * img.rows / (m * m / 4); ++i) {
        cv::circle(img, RandPoint(img, rng), rng.UniformInt(1, std::max(1, m / 10)),
                   Jitter(base_bgr, 0.5, rng), cv::FILLED);
      }
      for (int x = 0; x < img.cols; x += tile)
        cv::line(img, {x, 0}, {x, img.rows}, {60, 60, 60}, 3);
      for (int y = 0; y < img.rows; y += tile)
        cv::line(img, {0, y}, {img.cols, y}, {60, 60, 60}, 3);
      break;
    }
    case TextureStyle::kWood: {
      DrawPlanks(img, base_bgr, std::max(4, m), rng);
      for (int i = 0; i < 40; ++i) {
        cv::ellipse(img, RandPoint(img, rng),
                    cv::Size(rng.UniformInt(2, m / 2 + 3), rng.UniformInt(2, m / 4 + 2)), 0, 0, 360,
                    Contrast(base_bgr, rng), cv::FILLED, cv::LINE_AA);
      }
      for (int i = 0; i < 12; ++i) DrawText(img, Contrast(base_bgr, rng), 0.4 * m, rng);
      break;
    }
    case TextureStyle::kPrint:
      DrawPrint(img, base_bgr, rng);
      break;
  }
  // Slight blur: the renderer samples once per pixel, soft texel edges limit aliasing.
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.6);
  return tex;
}

}  // namespace loci::synth
