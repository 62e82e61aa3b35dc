// `loci synth --out DIR [--seed N] [--frames N] [--objects N] [--dynamic] [--noise] [--varied]
// [--det-noise] [--absent ID,...] [--moved ID,...] [--days-later D] ...`:
// renders a synthetic TUM-layout RGB-D sequence with exact ground truth (synth/).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli/commands.h"
#include "synth/sequence_writer.h"

namespace loci::cli {

void RegisterSynthCommands(CLI::App& app) {
  auto opt = std::make_shared<synth::SceneOptions>();
  auto out = std::make_shared<std::string>();
  auto gravity_only = std::make_shared<bool>(false);
  auto later_days = std::make_shared<double>(0.0);
  CLI::App* cmd = app.add_subcommand(
      "synth",
      "Render a synthetic indoor RGB-D sequence (TUM layout) with ground-truth poses, "
      "objects.json and detections.jsonl");
  cmd->add_option("--out", *out, "Output folder (created; existing files are overwritten)")
      ->required();
  cmd->add_option("--seed", opt->seed, "Random seed: same seed, same bytes")->capture_default_str();
  cmd->add_option("--frames", opt->num_frames, "Number of frames at 30 Hz")->capture_default_str();
  cmd->add_option("--objects", opt->num_objects, "Objects besides the table and the shelf, [0, 40]")
      ->capture_default_str();
  cmd->add_flag("--dynamic", opt->dynamic, "Add a walking person (class person, dynamic)");
  cmd->add_flag("--noise", opt->depth_noise,
                "Kinect-like depth noise, quantisation and edge dropouts (default: exact depth)");
  cmd->add_flag("--varied", opt->varied_layout,
                "Room size, table size and place, shelf or none and the object count from the seed");
  cmd->add_flag("--det-noise", opt->detector_noise,
                "Detector errors in detections.jsonl: jitter, misses, false boxes, confusions");
  cmd->add_option("--absent", opt->absent_ids,
                  "Object ids (as in objects.json) taken out of the room: a later session of it")
      ->delimiter(',');
  cmd->add_option("--moved", opt->moved_ids,
                  "Object ids put elsewhere on the same support: a later session of the room")
      ->delimiter(',');
  cmd->add_option("--days-later", *later_days,
                  "Stamps start this many days after the default start (a later session)")
      ->check(CLI::Range(0.0, 3650.0))
      ->capture_default_str();
  cmd->add_option("--width", opt->width_px, "Image width, px (fr1 intrinsics scaled)")
      ->capture_default_str();
  cmd->add_option("--height", opt->height_px, "Image height, px")->capture_default_str();
  cmd->add_option("--threads", opt->num_threads, "Worker threads, 0 = all cores")
      ->capture_default_str();
  cmd->add_flag("--accel-gravity-only", *gravity_only,
                "accelerometer.txt holds gravity only (default: gravity + camera acceleration)");
  cmd->callback([opt, out, gravity_only, later_days] {
    opt->accel_with_motion = !*gravity_only;
    opt->start_t_ns += std::llround(*later_days * 86400.0 * 1e6) * 1000;
    synth::SequenceStats stats;
    const Status s = synth::WriteSequence(*opt, *out, &stats);
    if (!s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      ExitCode() = 1;
      return;
    }
    std::printf("wrote %d frames (%dx%d), %d objects, %lld detections to %s\n", stats.frames,
                opt->width_px, opt->height_px, stats.objects,
                static_cast<long long>(stats.detections), out->c_str());
    std::printf("time %.2f s (%.1f ms/frame)\n", stats.seconds,
                1e3 * stats.seconds / std::max(1, stats.frames));
  });
}

}  // namespace loci::cli
