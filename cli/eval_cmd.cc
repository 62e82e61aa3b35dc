// `loci eval ate|rpe GT EST [--json]`: TUM RGB-D benchmark trajectory metrics.
#include <cmath>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "common/trajectory_eval.h"
#include "common/tum_io.h"

namespace loci::cli {
namespace {

nlohmann::json StatsJson(const ErrorStats& s, double scale = 1.0) {
  return {{"rmse", s.rmse * scale}, {"mean", s.mean * scale}, {"median", s.median * scale},
          {"std", s.std * scale},   {"min", s.min * scale},   {"max", s.max * scale}};
}

struct EvalArgs {
  std::string gt, est;
  bool json = false;
  double max_dt_s = 0.02;
  double offset_s = 0.0;
  double delta_s = 1.0;
};

bool LoadBoth(const EvalArgs& a, Trajectory* gt, Trajectory* est) {
  auto g = ReadTumTrajectory(a.gt);
  auto e = ReadTumTrajectory(a.est);
  if (!g.ok() || !e.ok()) {
    std::cerr << "error: " << (!g.ok() ? g.status() : e.status()).message() << "\n";
    return false;
  }
  *gt = std::move(*g);
  *est = std::move(*e);
  return true;
}

void RunAte(const EvalArgs& a) {
  Trajectory gt, est;
  if (!LoadBoth(a, &gt, &est)) {
    ExitCode() = 1;
    return;
  }
  AteOptions opt;
  opt.max_dt_ns = static_cast<int64_t>(std::llround(a.max_dt_s * 1e9));
  opt.offset_ns = static_cast<int64_t>(std::llround(a.offset_s * 1e9));
  auto r = ComputeAte(gt, est, opt);
  if (!r.ok()) {
    std::cerr << "error: " << r.status().message() << "\n";
    ExitCode() = 1;
    return;
  }
  if (a.json) {
    std::cout << nlohmann::json{{"metric", "ate"}, {"pairs", r->pairs},
                                {"trans_m", StatsJson(r->trans_m)}}
                     .dump(2)
              << "\n";
    return;
  }
  std::printf("ATE rmse %.4f m (%zu pairs)\n", r->trans_m.rmse, r->pairs);
  std::printf("  mean %.4f m  median %.4f m  std %.4f m  min %.4f m  max %.4f m\n",
              r->trans_m.mean, r->trans_m.median, r->trans_m.std, r->trans_m.min,
              r->trans_m.max);
}

void RunRpe(const EvalArgs& a) {
  Trajectory gt, est;
  if (!LoadBoth(a, &gt, &est)) {
    ExitCode() = 1;
    return;
  }
  RpeOptions opt;
  opt.delta_s = a.delta_s;
  opt.offset_ns = static_cast<int64_t>(std::llround(a.offset_s * 1e9));
  auto r = ComputeRpe(gt, est, opt);
  if (!r.ok()) {
    std::cerr << "error: " << r.status().message() << "\n";
    ExitCode() = 1;
    return;
  }
  const double deg = 180.0 / M_PI;
  if (a.json) {
    std::cout << nlohmann::json{{"metric", "rpe"},
                                {"pairs", r->pairs},
                                {"delta_s", r->delta_s},
                                {"trans_m_per_delta", StatsJson(r->trans_m)},
                                {"rot_deg_per_delta", StatsJson(r->rot_rad, deg)}}
                     .dump(2)
              << "\n";
    return;
  }
  std::printf("RPE trans rmse %.4f m/s, rot rmse %.3f deg/s (%zu pairs, delta %.2f s)\n",
              r->trans_m.rmse / r->delta_s, r->rot_rad.rmse * deg / r->delta_s, r->pairs,
              r->delta_s);
  std::printf("  trans mean %.4f median %.4f max %.4f m; rot mean %.3f median %.3f max %.3f deg\n",
              r->trans_m.mean, r->trans_m.median, r->trans_m.max, r->rot_rad.mean * deg,
              r->rot_rad.median * deg, r->rot_rad.max * deg);
}

}  // namespace

void RegisterEvalCommands(CLI::App& app) {
  CLI::App* eval = EvalGroup(app);
  auto args = std::make_shared<EvalArgs>();
  auto common = [args](CLI::App* c) {
    c->add_option("GT", args->gt, "ground-truth TUM trajectory (t tx ty tz qx qy qz qw)")
        ->required()
        ->check(CLI::ExistingFile);
    c->add_option("EST", args->est, "estimated TUM trajectory")->required()->check(CLI::ExistingFile);
    c->add_flag("--json", args->json, "print JSON instead of text");
    c->add_option("--offset", args->offset_s, "time offset added to EST stamps, s")
        ->capture_default_str();
  };
  CLI::App* ate = eval->add_subcommand(
      "ate", "Absolute trajectory error after rigid (SE3) Horn alignment, metres");
  common(ate);
  ate->add_option("--max-difference", args->max_dt_s, "stamp association window, s")
      ->capture_default_str();
  ate->callback([args] { RunAte(*args); });
  CLI::App* rpe = eval->add_subcommand("rpe", "Relative pose error over fixed time windows");
  common(rpe);
  rpe->add_option("--delta", args->delta_s, "window length, s")->capture_default_str();
  rpe->callback([args] { RunRpe(*args); });
}

}  // namespace loci::cli
