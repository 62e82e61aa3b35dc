// `loci detect IMAGE... [--model FILE] [--config FILE] [--json] [--annotate OUT_DIR]`: runs the
// configured detector on images and prints class, score and box (x, y, w, h in pixels).
// --json prints detections.jsonl lines (docs/formats.md) with an extra "image" key, so the
// output can feed the file detector (`detector: {type: file}`).
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli/commands.h"
#include "common/detections_io.h"
#include "common/time.h"
#include "detection/detection_config.h"

namespace loci::cli {
namespace {

struct DetectArgs {
  std::vector<std::string> images;
  std::string model;
  std::string config;
  float threshold = -1.f;
  bool all_classes = false;
  bool json = false;
  std::string annotate_dir;
  int threads = 0;
};

void Annotate(cv::Mat* bgr, const std::vector<Detection2D>& dets) {
  for (const Detection2D& d : dets) {
    const cv::Scalar colour((d.class_id * 67) % 256, (d.class_id * 131 + 80) % 256,
                            (d.class_id * 29 + 160) % 256);
    cv::rectangle(*bgr, cv::Rect(d.box_px), colour, 2);
    char label[96];
    std::snprintf(label, sizeof(label), "%s %.2f", d.class_name.c_str(), d.score);
    int base = 0;
    const cv::Size ts = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &base);
    const cv::Point org(static_cast<int>(d.box_px.x),
                        std::max(ts.height + 2, static_cast<int>(d.box_px.y) - 3));
    cv::rectangle(*bgr, cv::Rect(org.x, org.y - ts.height - 2, ts.width + 2, ts.height + 4), colour,
                  cv::FILLED);
    cv::putText(*bgr, label, org + cv::Point(1, 0), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
}

int RunDetect(const DetectArgs& a) {
  const std::string config = a.config.empty() ? detection::DefaultDetectionConfigPath() : a.config;
  auto cfg = detection::LoadDetectionConfig(config);
  if (!cfg.ok()) {
    std::cerr << "error: " << cfg.status().message() << "\n";
    return 1;
  }
  detection::DetectorOptions opt = cfg->detector;
  if (!a.model.empty()) {
    opt.model_path = std::filesystem::absolute(a.model).string();
    opt.class_names_path.clear();
    // The shipped NanoDet-m is 320x320; YOLOX-Nano 416x416.
    const bool nanodet = opt.model_path.find("nanodet") != std::string::npos;
    opt.type = nanodet ? "nanodet" : "yolox";
    opt.input_size_px = nanodet ? 320 : 416;
    if (nanodet) opt.nms_iou = 0.6f;
  }
  if (a.threshold >= 0.f) {
    opt.score_threshold = a.threshold;
    opt.class_score_thresholds.clear();
  }
  if (a.all_classes) opt.classes.clear();
  if (a.threads > 0) opt.num_threads = a.threads;
  auto detector = detection::MakeDetector(opt);
  if (!detector.ok()) {
    std::cerr << "error: " << detector.status().message() << "\n";
    return 1;
  }
  if (!a.annotate_dir.empty()) std::filesystem::create_directories(a.annotate_dir);
  int failures = 0;
  for (const std::string& path : a.images) {
    cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
    if (bgr.empty()) {
      std::cerr << "error: cannot read image " << path << "\n";
      ++failures;
      continue;
    }
    // TUM-style names carry the stamp ("1305031249.497685.jpg"); otherwise 0.
    auto t_ns = ParseSecondsToNs(std::filesystem::path(path).stem().string());
    FrameDetections frame{t_ns.ok() ? *t_ns : 0, {}};
    auto dets = (*detector)->Detect(bgr, frame.t_ns);
    if (!dets.ok()) {
      std::cerr << "error: " << path << ": " << dets.status().message() << "\n";
      ++failures;
      continue;
    }
    frame.detections = std::move(*dets);
    if (a.json) {
      nlohmann::json line = nlohmann::json::parse(DetectionsToJsonLine(frame));
      line["image"] = path;
      std::cout << line.dump() << "\n";
    } else {
      std::printf("%s: %zu detections (%s)\n", path.c_str(), frame.detections.size(),
                  (*detector)->Name().c_str());
      for (const Detection2D& d : frame.detections) {
        std::printf("  %-14s %.2f  [%.0f, %.0f, %.0f, %.0f]\n", d.class_name.c_str(), d.score,
                    d.box_px.x, d.box_px.y, d.box_px.width, d.box_px.height);
      }
    }
    if (!a.annotate_dir.empty()) {
      Annotate(&bgr, frame.detections);
      const std::string out =
          (std::filesystem::path(a.annotate_dir) / std::filesystem::path(path).stem()).string() +
          ".jpg";
      if (!cv::imwrite(out, bgr)) {
        std::cerr << "error: cannot write " << out << "\n";
        ++failures;
      }
    }
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

void RegisterDetectCommand(CLI::App& app) {
  auto args = std::make_shared<DetectArgs>();
  CLI::App* c = app.add_subcommand(
      "detect", "Detect objects in images (YOLOX-Nano by default; config/detection.yaml)");
  c->add_option("IMAGE", args->images, "images to run the detector on")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--model", args->model,
                "ONNX model (a path containing 'nanodet' selects the NanoDet decoder, 320 px)")
      ->check(CLI::ExistingFile);
  c->add_option("--config", args->config, "detection YAML (default: config/detection.yaml)");
  c->add_option("--threshold", args->threshold,
                "score threshold for every class (default: the config's per-class values)");
  c->add_flag("--all-classes", args->all_classes, "keep all 80 COCO classes, not only `mapped`");
  c->add_option("--threads", args->threads, "OpenCV threads (0 = config / OpenCV default)");
  c->add_flag("--json", args->json, "print detections.jsonl lines (plus \"image\")");
  c->add_option("--annotate", args->annotate_dir, "write images with boxes to this folder");
  c->callback([args] { ExitCode() = RunDetect(*args); });
}

}  // namespace loci::cli
