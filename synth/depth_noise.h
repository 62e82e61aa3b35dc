// Kinect-like depth degradation for synthetic depth images (Khoshelham & Elberink 2012 style):
// axial noise sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m, disparity quantisation to 1/8 pixel of
// a structured-light sensor (focal 580 px, baseline 7.5 cm), and missing readings at depth
// discontinuities.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace loci::synth {

struct DepthNoiseOptions {
  double focal_px = 580.0;         // IR camera focal length of the disparity model, px
  double baseline_m = 0.075;       // projector-camera baseline, m
  double subpixel = 8.0;           // disparity steps per pixel
  double edge_jump_ratio = 0.04;   // a neighbour differing by more than this fraction of z
                                   // marks a depth edge
  double edge_dropout_prob = 0.6;  // probability that an edge pixel reads 0
};

// Noise standard deviation at depth z_m (m).
double KinectSigmaM(double z_m);

// Returns a degraded copy of depth_m (CV_32FC1, metres, 0 = no reading). Deterministic for seed.
cv::Mat ApplyKinectNoise(const cv::Mat& depth_m, uint64_t seed,
                         const DepthNoiseOptions& options = {});

}  // namespace loci::synth
