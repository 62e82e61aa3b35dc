// CPU ray caster of a synthetic scene: one ray per pixel centre against the room, the boxes,
// cylinders and spheres of the objects, Lambertian shading with a ceiling point light plus a
// weak headlight, exact z-depth and per-pixel object ids. Rows are shared among std::threads.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/se3.h"
#include "synth/scene.h"

namespace loci::synth {

struct RenderedFrame {
  int64_t t_ns = 0;
  SE3d T_world_cam = SE3d::Identity();
  cv::Mat bgr;          // CV_8UC3
  cv::Mat depth_u16;    // CV_16UC1, scene.options.depth_scale per metre, 0 = no reading (out of
                        // [min_depth_m, max_depth_m] or dropped by the noise model)
  cv::Mat depth_m;      // CV_32FC1, exact z-depth of the surface seen (m), before any noise
  cv::Mat instance_id;  // CV_32SC1, SceneObject::id of the surface seen, 0 = room
};

// Renders the scene seen from T_world_cam at absolute stamp t_ns (dynamic objects move with
// t_ns). Depth noise follows scene.options.depth_noise, seeded by (seed, t_ns), so a frame is
// reproducible, and the result does not depend on the thread count. num_threads 0 =
// scene.options.num_threads (0 there = all cores). An invalid camera gives empty images.
RenderedFrame Render(const Scene& scene, const SE3d& T_world_cam, const PinholeCamera& camera,
                     int64_t t_ns, int num_threads = 0);

}  // namespace loci::synth
