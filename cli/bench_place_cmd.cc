// `loci bench place [--tum DIR] [--sizes 1000,10000] [--queries 200] [--config FILE]`: place
// recognition costs (server/place) on a real TUM sequence.
//  1. Extraction: each frame's colour image is encoded as the client sends it (JPEG q90, not
//     timed) beside its 16-bit depth PNG; ExtractFeaturesFromEncoded (decode + ORB + depth) is
//     timed, wall clock and thread CPU. Bytes per keyframe of the stored features (LPF1).
//  2. Query cost at each database size: the database is filled with "rooms", each a copy of the
//     sequence's real keyframes whose descriptors are XORed with the room's random 256-bit mask
//     (Hamming distances within a room are those of the real data; rooms share no words, like
//     different places). Then `--queries` keyframes of one more such room go through the
//     server's step: quantise (adding words), query, insert; each stage is timed.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <span>
#include <sstream>

#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "common/config.h"
#include "common/image_codec.h"
#include "common/time.h"
#include "common/tum_io.h"
#include "server/place/dense_refinement.h"
#include "server/place/feature_codec.h"
#include "server/place/geometric_verification.h"
#include "server/place/place_database.h"

namespace loci::cli {
namespace {

using place::KeyframeFeatures;

struct BenchPlaceArgs {
  std::string tum_dir;
  std::string config;
  std::vector<int> sizes = {1000, 10000};
  int queries = 200;
  int max_frames = 0;
  uint64_t seed = 1;
};

struct Stats {
  double median = 0, p95 = 0, mean = 0;
};

Stats Summarise(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  s.median = Percentile(v, 0.5);
  s.p95 = Percentile(v, 0.95);
  for (const double x : v) s.mean += x / static_cast<double>(v.size());
  return s;
}

// Peak resident memory of the process, MiB.
double PeakRssMib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}


std::string DefaultTumDir() {
  const std::string full = SourceDir() + "/../shared/data/tum_fr1_rpy";
  if (!DataDirFromEnv().empty() && std::filesystem::exists(DataDirFromEnv() + "/tum_fr1_rpy")) {
    return DataDirFromEnv() + "/tum_fr1_rpy";
  }
  return std::filesystem::exists(full + "/rgb.txt")
             ? full
             : SourceDir() + "/tests/data/tum_fr1_rpy_sample";
}

// Features of every frame, with the extraction figures printed.
StatusOr<std::vector<KeyframeFeatures>> ExtractAll(const TumSequence& seq, int max_frames,
                                                   const place::FeatureOptions& options) {
  std::vector<KeyframeFeatures> out;
  std::vector<double> wall_ms, cpu_ms, bytes, image_bytes;
  const size_t n =
      max_frames > 0 ? std::min<size_t>(max_frames, seq.frames.size()) : seq.frames.size();
  for (size_t i = 0; i < n; ++i) {
    LOCI_ASSIGN_OR_RETURN(const std::string png, ReadFileBytes(seq.frames[i].depth_path));
    const cv::Mat bgr = cv::imread(seq.frames[i].rgb_path, cv::IMREAD_COLOR);
    LOCI_ASSIGN_OR_RETURN(const std::string jpeg, EncodeJpeg(bgr, 90));
    const double cpu0 = ThreadCpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    LOCI_ASSIGN_OR_RETURN(
        KeyframeFeatures f,
        place::ExtractFeaturesFromEncoded(jpeg, png, 5000.0, PinholeCamera::TumFr1(), options));
    wall_ms.push_back(MsSince(t0));
    cpu_ms.push_back(ThreadCpuMs() - cpu0);
    LOCI_ASSIGN_OR_RETURN(const std::string stored, place::EncodeFeatures(f));
    bytes.push_back(static_cast<double>(stored.size()));
    image_bytes.push_back(static_cast<double>(jpeg.size() + png.size()));
    out.push_back(std::move(f));
  }
  const Stats w = Summarise(wall_ms), c = Summarise(cpu_ms), b = Summarise(bytes);
  std::printf(
      "extraction (JPEG + PNG decode, ORB %d, depth): %.1f ms/keyframe median, %.1f p95, "
      "%.1f mean wall; %.1f ms median thread CPU (%zu keyframes)\n",
      options.max_features, w.median, w.p95, w.mean, c.median, out.size());
  std::printf(
      "features stored: %.0f bytes/keyframe mean (%.1f KB), vs %.0f KB of JPEG q90 + "
      "depth PNG\n",
      b.mean, b.mean / 1024, Summarise(image_bytes).mean / 1024);
  return out;
}

// Verification of frame i against frame i - 10 (a third of a second earlier), every 5th frame.
void BenchVerification(const std::vector<KeyframeFeatures>& kfs,
                       const place::VerifyOptions& options) {
  std::vector<double> ms;
  int accepted = 0;
  for (size_t i = 10; i < kfs.size(); i += 5) {
    const auto t0 = std::chrono::steady_clock::now();
    accepted += place::VerifyPair(kfs[i], kfs[i - 10], options).accepted ? 1 : 0;
    ms.push_back(MsSince(t0));
  }
  const Stats s = Summarise(ms);
  std::printf(
      "verification of a pair (frames 10 apart): %.1f ms median, %.1f p95 (%d of %zu "
      "accepted)\n",
      s.median, s.p95, accepted, ms.size());
}

// The relative pose of frames a and b (p_a = T_a_b p_b) from the ground truth, when it has them.
std::optional<SE3d> TruthAB(const TumSequence& seq, size_t a, size_t b) {
  auto at = [&](int64_t t_ns) -> std::optional<SE3d> {
    const StampedPose* p =
        NearestByTime(std::span<const StampedPose>(seq.groundtruth), t_ns, 10'000'000);
    return p ? std::optional<SE3d>(p->T_world_cam) : std::nullopt;
  };
  const std::optional<SE3d> Ta = at(seq.frames[a].rgb_t_ns), Tb = at(seq.frames[b].rgb_t_ns);
  if (!Ta || !Tb) return std::nullopt;
  return Ta->inverse() * *Tb;
}

// Dense refinement (place.dense) of the verified pairs of BenchVerification: its cost, and with
// ground truth how far the sparse and the refined relative poses are from it.
void BenchDense(const TumSequence& seq, const std::vector<KeyframeFeatures>& kfs,
                const place::PlaceOptions& options) {
  std::vector<double> make_ms, refine_ms, sparse_deg, dense_deg, sparse_mm, dense_mm;
  int refused = 0;
  place::DenseRefiner refiner(options.dense);  // one per aligner, as on the server
  auto frame = [&](size_t i) {
    cv::Mat depth_m;
    cv::imread(seq.frames[i].depth_path, cv::IMREAD_UNCHANGED)
        .convertTo(depth_m, CV_32F, 1 / 5000.0);
    const cv::Mat bgr = cv::imread(seq.frames[i].rgb_path, cv::IMREAD_COLOR);
    const double t0 = ThreadCpuMs();
    place::DenseFrame f = place::MakeDenseFrame(bgr, depth_m, kfs[i].camera, options.dense);
    make_ms.push_back(ThreadCpuMs() - t0);
    return f;
  };
  for (size_t i = 10; i < kfs.size(); i += 5) {
    const place::Verification v = place::VerifyPair(kfs[i], kfs[i - 10], options.verify);
    if (!v.accepted) continue;
    const place::DenseFrame a = frame(i), b = frame(i - 10);
    const double t0 = ThreadCpuMs();
    const std::optional<SE3d> refined = refiner.Refine(a, b, v.T_a_b);
    refine_ms.push_back(ThreadCpuMs() - t0);
    refused += !refined;
    const std::optional<SE3d> truth = TruthAB(seq, i, i - 10);
    if (!truth) continue;
    const SE3d dense = refined.value_or(v.T_a_b);
    sparse_deg.push_back(RotationAngleRad(truth->inverse() * v.T_a_b) * 180 / M_PI);
    dense_deg.push_back(RotationAngleRad(truth->inverse() * dense) * 180 / M_PI);
    sparse_mm.push_back((truth->inverse() * v.T_a_b).translation().norm() * 1e3);
    dense_mm.push_back((truth->inverse() * dense).translation().norm() * 1e3);
  }
  const Stats m = Summarise(make_ms), r = Summarise(refine_ms);
  std::printf(
      "dense refinement (scale %.2f, %d levels): images %.1f ms/keyframe, alignment %.1f ms "
      "median, %.1f p95 thread CPU per pair (%zu pairs, %d refused)\n",
      options.dense.scale, options.dense.levels, m.median, r.median, r.p95, refine_ms.size(),
      refused);
  if (sparse_deg.empty()) return;
  std::printf(
      "  against the ground truth (frames as read): sparse %.2f deg, %.1f mm median -> dense "
      "%.2f deg, %.1f mm\n",
      Summarise(sparse_deg).median, Summarise(sparse_mm).median, Summarise(dense_deg).median,
      Summarise(dense_mm).median);
}

cv::Mat MaskedDescriptors(const cv::Mat& descriptors, const cv::Mat& mask_row) {
  cv::Mat out(descriptors.size(), descriptors.type());
  for (int r = 0; r < descriptors.rows; ++r)
    cv::bitwise_xor(descriptors.row(r), mask_row, out.row(r));
  return out;
}

cv::Mat RandomMask(std::mt19937_64& rng) {
  cv::Mat mask(1, place::kDescriptorBytes, CV_8UC1);
  for (int i = 0; i < mask.cols; ++i) mask.at<uint8_t>(0, i) = static_cast<uint8_t>(rng());
  return mask;
}

// Fills the database with masked copies of the keyframes up to `size`; returns ms per insert.
double FillDatabase(const std::vector<KeyframeFeatures>& kfs, int size, std::mt19937_64& rng,
                    place::PlaceDatabase* db) {
  const auto t0 = std::chrono::steady_clock::now();
  int64_t id = 0;
  for (int room = 0; id < size; ++room) {
    const cv::Mat mask = RandomMask(rng);
    for (size_t i = 0; i < kfs.size() && id < size; ++i, ++id) {
      const place::BowVector bow = db->Quantise(MaskedDescriptors(kfs[i].descriptors, mask), true);
      (void)db->Insert(id, "room" + std::to_string(room), bow);
    }
  }
  return MsSince(t0) / static_cast<double>(size);
}

void BenchSize(const std::vector<KeyframeFeatures>& kfs, int size, const BenchPlaceArgs& a,
               const place::PlaceOptions& options) {
  std::mt19937_64 rng(a.seed);
  place::PlaceDatabase db(options.vocabulary, options.query);
  const double fill_ms = FillDatabase(kfs, size, rng, &db);
  const cv::Mat mask = RandomMask(rng);
  std::vector<double> quantise_ms, query_ms, insert_ms, total_ms;
  size_t candidates = 0, own_room_top1 = 0, descriptors = 0, new_words = 0;
  const int stride = std::max(1, static_cast<int>(kfs.size()) / std::max(1, a.queries));
  for (int q = 0; q < a.queries; ++q) {
    const KeyframeFeatures& kf = kfs[(static_cast<size_t>(q) * stride) % kfs.size()];
    const cv::Mat desc = MaskedDescriptors(kf.descriptors, mask);
    const size_t words_before = db.words();
    const auto t0 = std::chrono::steady_clock::now();
    const place::BowVector bow = db.Quantise(desc, true);
    const double t_quantise = MsSince(t0);
    new_words += db.words() - words_before;
    descriptors += static_cast<size_t>(desc.rows);
    const auto t1 = std::chrono::steady_clock::now();
    const std::vector<place::PlaceCandidate> found = db.Query(bow, "query-room");
    const double t_query = MsSince(t1);
    candidates += found.size();
    own_room_top1 += !found.empty() && found[0].robot == "query-room" ? 1 : 0;
    const auto t2 = std::chrono::steady_clock::now();
    (void)db.Insert(size + q, "query-room", bow);
    const double t_insert = MsSince(t2);
    quantise_ms.push_back(t_quantise);
    query_ms.push_back(t_query);
    insert_ms.push_back(t_insert);
    total_ms.push_back(t_quantise + t_query + t_insert);
  }
  const Stats qz = Summarise(quantise_ms), qr = Summarise(query_ms), in = Summarise(insert_ms),
              tt = Summarise(total_ms);
  std::printf(
      "database %6d keyframes (%zu words, tree depth %d; filled at %.2f ms/keyframe; "
      "peak RSS %.0f MiB):\n",
      size, db.words(), db.vocabulary().depth(), fill_ms, PeakRssMib());
  std::printf(
      "  per keyframe: quantise %.2f ms, query %.2f ms, insert %.2f ms (medians); "
      "total %.2f ms median, %.2f p95, %.2f mean\n",
      qz.median, qr.median, in.median, tt.median, tt.p95, tt.mean);
  std::printf(
      "  %.1f candidates/query, best candidate from the query's own room for %zu of %d; "
      "%.0f%% of the query descriptors founded new words\n",
      static_cast<double>(candidates) / a.queries, own_room_top1, a.queries,
      100.0 * static_cast<double>(new_words) / static_cast<double>(descriptors));
}

int RunBenchPlace(const BenchPlaceArgs& a) {
  place::PlaceOptions options;
  const std::string cfg = a.config.empty() ? SourceDir() + "/config/server.yaml" : a.config;
  if (auto node = LoadYamlFile(cfg); node.ok()) {
    if (Status s = options.FromYaml((*node)["place"]); !s.ok()) {
      std::cerr << "error: " << cfg << ": " << s.message() << "\n";
      return 1;
    }
  } else if (!a.config.empty()) {
    std::cerr << "error: " << node.status().message() << "\n";
    return 1;
  }
  const std::string dir = a.tum_dir.empty() ? DefaultTumDir() : a.tum_dir;
  auto seq = LoadTumSequence(dir);
  if (!seq.ok()) {
    std::cerr << "error: " << seq.status().message() << "\n";
    return 1;
  }
  cv::setNumThreads(1);
  std::printf("loci bench place: %s (%zu frames), one thread\n", dir.c_str(), seq->frames.size());
  auto kfs = ExtractAll(*seq, a.max_frames, options.features);
  if (!kfs.ok()) {
    std::cerr << "error: " << kfs.status().message() << "\n";
    return 1;
  }
  BenchVerification(*kfs, options.verify);
  if (options.dense.enabled) BenchDense(*seq, *kfs, options);
  for (const int size : a.sizes) BenchSize(*kfs, size, a, options);
  return 0;
}

}  // namespace

void RegisterBenchPlaceCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchPlaceArgs>();
  CLI::App* c = bench->add_subcommand(
      "place", "place recognition: feature extraction, feature bytes, query time vs map size");
  c->add_option("--tum", args->tum_dir,
                "TUM RGB-D folder (default: $LOCI_DATA/tum_fr1_rpy, ../shared/data/tum_fr1_rpy, "
                "else the shipped sample)");
  c->add_option("--sizes", args->sizes, "database sizes, keyframes")
      ->delimiter(',')
      ->capture_default_str();
  c->add_option("--queries", args->queries, "keyframes timed per size")->capture_default_str();
  c->add_option("--max-frames", args->max_frames, "use the first N frames (0 = all)");
  c->add_option("--config", args->config,
                "server YAML whose `place` section is used "
                "(default: config/server.yaml)");
  c->add_option("--seed", args->seed, "seed of the room masks")->capture_default_str();
  c->callback([args] { ExitCode() = RunBenchPlace(*args); });
}

}  // namespace loci::cli
