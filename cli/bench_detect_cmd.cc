// `loci bench detect --tum DIR [--frames N] [--config FILE] [--server-detector FILE]`: detector
// speed (ms per frame, median and p95, at 1 and 2 OpenCV threads) for the shipped YOLOX-Nano and
// NanoDet-m, and for the server's detector of a loci-server --detector YAML,
// detections per frame, depth-mask time and tracker time per frame, on a TUM RGB-D folder.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "common/config.h"
#include "common/tum_io.h"
#include "detection/detection_config.h"

namespace loci::cli {
namespace {

struct BenchDetectArgs {
  std::string tum_dir;
  int frames = 60;
  std::string config;
  std::string server_detector;  // loci-server --detector YAML; "" = none
};

double ElapsedMs(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Runs `opt`'s detector over the images after one warm-up forward; prints its row of the table.
StatusOr<std::vector<std::vector<Detection2D>>> TimeDetector(
    const detection::DetectorOptions& opt, const std::vector<cv::Mat>& images,
    const std::vector<int64_t>& stamps) {
  LOCI_ASSIGN_OR_RETURN(auto det, detection::MakeDetector(opt));
  (void)det->Detect(images[0], 0);  // warm-up: the first forward allocates
  std::vector<double> ms;
  size_t total = 0;
  std::vector<std::vector<Detection2D>> all;
  for (size_t i = 0; i < images.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    LOCI_ASSIGN_OR_RETURN(std::vector<Detection2D> r, det->Detect(images[i], stamps[i]));
    ms.push_back(ElapsedMs(t0));
    total += r.size();
    all.push_back(std::move(r));
  }
  double mean = 0.0;
  for (double v : ms) mean += v / ms.size();
  std::printf("%-22s %7d %10.1f %10.1f %10.1f %9.2f\n", det->Name().c_str(), opt.num_threads,
              Percentile(ms, 0.5), Percentile(ms, 0.95), mean,
              static_cast<double>(total) / images.size());
  return all;
}

// The detector of a loci-server --detector YAML (its `detector:` section), as configured.
Status TimeServerDetector(const std::string& path, const std::vector<cv::Mat>& images,
                          const std::vector<int64_t>& stamps) {
  LOCI_ASSIGN_OR_RETURN(YAML::Node root, LoadYamlFile(path));
  if (!root["detector"]) return absl::InvalidArgumentError(path + ": no `detector:` section");
  YAML::Node node = YAML::Clone(root["detector"]);
  for (const char* key : {"enabled", "mode", "threads"}) node.remove(key);  // the server's keys
  const ConfigFileScope scope(path);
  LOCI_ASSIGN_OR_RETURN(detection::DetectorOptions opt,
                        detection::DetectorOptions::FromYaml(node, SourceDir()));
  std::printf("server detector of %s:\n", path.c_str());
  return TimeDetector(opt, images, stamps).status();
}

int RunBenchDetect(const BenchDetectArgs& a) {
  auto seq = LoadTumSequence(a.tum_dir);
  if (!seq.ok()) {
    std::cerr << "error: " << seq.status().message() << "\n";
    return 1;
  }
  auto cfg = detection::LoadDetectionConfig(
      a.config.empty() ? detection::DefaultDetectionConfigPath() : a.config);
  if (!cfg.ok()) {
    std::cerr << "error: " << cfg.status().message() << "\n";
    return 1;
  }
  const size_t n = std::min<size_t>(seq->frames.size(), a.frames > 0 ? a.frames : SIZE_MAX);
  std::vector<cv::Mat> images, depths;
  std::vector<int64_t> stamps;
  for (size_t i = 0; i < n; ++i) {
    stamps.push_back(seq->frames[i].rgb_t_ns);
    images.push_back(cv::imread(seq->frames[i].rgb_path, cv::IMREAD_COLOR));
    depths.push_back(cv::imread(seq->frames[i].depth_path, cv::IMREAD_UNCHANGED));
    if (images.back().empty()) {
      std::cerr << "error: cannot read " << seq->frames[i].rgb_path << "\n";
      return 1;
    }
  }
  std::printf("loci bench detect: %zu frames of %s (%dx%d), cv threads available %d\n", n,
              a.tum_dir.c_str(), images[0].cols, images[0].rows, cv::getNumberOfCPUs());
  std::printf("%-22s %7s %10s %10s %10s %9s\n", "detector", "threads", "median_ms", "p95_ms",
              "mean_ms", "dets/frm");

  struct Model {
    const char* type;
    const char* path;
    int input;
    float nms;
  };
  const Model models[] = {{"yolox", "models/yolox_nano/yolox_nano.onnx", 416, 0.45f},
                          {"nanodet", "models/nanodet_m/nanodet_m_320.onnx", 320, 0.6f}};
  std::vector<std::vector<Detection2D>> yolox_dets;
  for (const Model& m : models) {
    for (int threads : {1, 2}) {
      detection::DetectorOptions opt = cfg->detector;
      opt.type = m.type;
      opt.model_path = SourceDir() + "/" + m.path;
      opt.class_names_path.clear();
      opt.input_size_px = m.input;
      opt.nms_iou = m.nms;
      opt.num_threads = threads;
      auto all = TimeDetector(opt, images, stamps);
      if (!all.ok()) {
        std::cerr << "error: " << all.status().message() << "\n";
        return 1;
      }
      if (std::string(m.type) == "yolox" && threads == 1) yolox_dets = *std::move(all);
    }
  }
  if (!a.server_detector.empty()) {
    const Status s = TimeServerDetector(a.server_detector, images, stamps);
    if (!s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      return 1;
    }
  }

  // Depth masks and tracking on the YOLOX detections (single thread: both are per-box loops).
  cv::setNumThreads(1);
  std::vector<double> mask_ms, track_us;
  detection::MultiObjectTracker tracker(cfg->tracker);
  size_t masks = 0;
  for (size_t i = 0; i < n; ++i) {
    std::vector<Detection2D> dets = yolox_dets[i];
    auto t0 = std::chrono::steady_clock::now();
    if (!depths[i].empty()) detection::AttachDepthMasks(depths[i], &dets, cfg->mask);
    mask_ms.push_back(ElapsedMs(t0));
    for (const auto& d : dets) masks += !d.mask.empty();
    t0 = std::chrono::steady_clock::now();
    tracker.Update(images[i], &dets);
    track_us.push_back(ElapsedMs(t0) * 1e3);
  }
  std::printf("depth masks (yolox boxes): median %.2f ms, p95 %.2f ms per frame, %zu masks\n",
              Percentile(mask_ms, 0.5), Percentile(mask_ms, 0.95), masks);
  std::printf("tracker (with HSV appearance): median %.0f us, p95 %.0f us per frame, %lld ids\n",
              Percentile(track_us, 0.5), Percentile(track_us, 0.95),
              static_cast<long long>(tracker.num_confirmed_ids()));
  return 0;
}

}  // namespace

void RegisterBenchDetectCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchDetectArgs>();
  CLI::App* c = bench->add_subcommand(
      "detect", "detector ms/frame at 1 and 2 threads, masks and tracker time on a TUM folder");
  c->add_option("--tum", args->tum_dir, "TUM RGB-D folder (rgb.txt, depth.txt)")
      ->required()
      ->check(CLI::ExistingDirectory);
  c->add_option("--frames", args->frames, "frames to run (0 = all)")->capture_default_str();
  c->add_option("--config", args->config, "detection YAML (default: config/detection.yaml)");
  c->add_option("--server-detector", args->server_detector,
                "also time a loci-server --detector YAML's model (config/server-detector.yaml)")
      ->check(CLI::ExistingFile);
  c->callback([args] { ExitCode() = RunBenchDetect(*args); });
}

}  // namespace loci::cli
