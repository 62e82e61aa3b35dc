// `loci objects [--server HOST:PORT] [--class C] [--json]`: the running server's objects as a
// table (id, class, confidence, centroid, extent, last seen, robots); `loci stats [--server
// HOST:PORT] [--json]`: its counters. Both over gRPC; --json prints the proto JSON (the same as
// GET /api/objects and GET /api/stats).
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/query_client.h"

namespace loci::cli {
namespace {

struct ObjectsArgs : ServerArgs {
  std::vector<std::string> classes;
  double min_confidence = 0;
  bool confirmed_only = false;
};

// UTC wall time of a stamp, "2026-11-21 08:47:59" ("-" for 0).
std::string Stamp(int64_t t_ns) {
  if (t_ns <= 0) return "-";
  const std::time_t t = static_cast<std::time_t>(t_ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S", &tm);
  return buf;
}

int RunObjects(const ObjectsArgs& a) {
  loci::v1::FindObjectsRequest req;
  for (const std::string& c : a.classes) req.add_classes(c);
  req.set_min_confidence(a.min_confidence);
  req.set_confirmed_only(a.confirmed_only);
  req.set_include_islands(true);
  loci::v1::FindObjectsResponse resp;
  if (std::optional<int> done = CallQuery(a, &loci::v1::Query::Stub::FindObjects, req, &resp)) {
    return *done;
  }
  std::printf("%6s  %-16s %5s  %-22s %-18s %-19s %s\n", "id", "class", "conf", "centroid (m)",
              "extent (m)", "last seen (UTC)", "robots");
  for (const auto& o : resp.objects()) {
    const auto& lo = o.aabb().min_m();
    const auto& hi = o.aabb().max_m();
    std::string robots;
    for (const auto& r : o.robots()) robots += (robots.empty() ? "" : ",") + r;
    char centroid[64], extent[64];
    std::snprintf(centroid, sizeof(centroid), "(%.2f, %.2f, %.2f)", o.centroid_m().x(),
                  o.centroid_m().y(), o.centroid_m().z());
    std::snprintf(extent, sizeof(extent), "%.2f x %.2f x %.2f", hi.x() - lo.x(), hi.y() - lo.y(),
                  hi.z() - lo.z());
    std::printf("%6lld  %-16s %5.2f  %-22s %-18s %-19s %s%s\n", static_cast<long long>(o.id()),
                o.class_name().c_str(), o.confidence(), centroid, extent,
                Stamp(o.last_seen_ns()).c_str(), robots.c_str(),
                o.island().empty() ? "" : ("  [island " + o.island() + ": its own frame]").c_str());
  }
  std::printf("%d objects\n", resp.objects_size());
  return 0;
}

// The sessions (aligned or islands) and what place recognition did.
void PrintAlignment(const loci::v1::GetStatsResponse& resp) {
  const loci::v1::AlignmentStats& a = resp.alignment();
  if (a.enabled()) {
    std::printf("place recognition  %.1f ms per keyframe, %llu keyframes indexed, %llu words\n",
                a.place_ms_mean(), static_cast<unsigned long long>(a.keyframes_indexed()),
                static_cast<unsigned long long>(a.vocabulary_words()));
    std::printf("features read      %llu from the database (%llu unreadable)\n",
                static_cast<unsigned long long>(a.features_read()),
                static_cast<unsigned long long>(a.features_missing()));
    std::printf("dense refinement   %llu matches refined, %llu refused, %llu without images; "
                "%llu keyframes' images read from the database\n",
                static_cast<unsigned long long>(a.dense_refined()),
                static_cast<unsigned long long>(a.dense_refused()),
                static_cast<unsigned long long>(a.dense_without_images()),
                static_cast<unsigned long long>(a.dense_frames_read()));
    std::printf("merges             %llu accepted, %llu disagreeing matches; %llu verified, "
                "%llu rejected candidates; %llu keyframes queried ahead of a backlog, %llu "
                "merges from them; %llu islands aligned by an aligned robot's keyframes\n",
                static_cast<unsigned long long>(a.merges_accepted()),
                static_cast<unsigned long long>(a.merge_resets()),
                static_cast<unsigned long long>(a.verified()),
                static_cast<unsigned long long>(a.rejected()),
                static_cast<unsigned long long>(a.queries_ahead()),
                static_cast<unsigned long long>(a.merges_ahead()),
                static_cast<unsigned long long>(a.islands_pulled()));
    if (a.merged_keyframes() > 0) {
      std::printf("held keyframes     %llu entered the map on alignments; the last %llu in %.0f "
                  "ms, %llu chunks; mapping paused at most %.0f ms (%.0f ms since start)\n",
                  static_cast<unsigned long long>(a.merged_keyframes()),
                  static_cast<unsigned long long>(a.last_merge_keyframes()), a.last_merge_ms(),
                  static_cast<unsigned long long>(a.last_merge_chunks()),
                  a.last_merge_longest_hold_ms(), a.merge_longest_hold_ms());
    }
  }
  const loci::v1::PoseGraphStats& g = resp.pose_graph();
  if (g.enabled()) {
    std::printf("loop closure       %llu loop and %llu merge matches verified; %llu solves "
                "(%.0f ms mean) moved %llu keyframes\n",
                static_cast<unsigned long long>(g.loop_matches()),
                static_cast<unsigned long long>(g.merge_matches()),
                static_cast<unsigned long long>(g.optimizations()), g.solve_ms_mean(),
                static_cast<unsigned long long>(g.keyframes_moved()));
    if (g.optimizations() > 0) {
      std::printf("pose graph         %llu keyframes, %llu edges, loops %llu kept / %llu rejected, "
                  "merges %llu kept / %llu rejected, %llu unconnected parts%s, %llu gravity "
                  "priors, %.0f ms\n",
                  static_cast<unsigned long long>(g.nodes()),
                  static_cast<unsigned long long>(g.edges()),
                  static_cast<unsigned long long>(g.loops_accepted()),
                  static_cast<unsigned long long>(g.loops_rejected()),
                  static_cast<unsigned long long>(g.merges_accepted()),
                  static_cast<unsigned long long>(g.merges_rejected()),
                  static_cast<unsigned long long>(g.islands()), g.four_dof() ? ", 4-DoF" : "",
                  static_cast<unsigned long long>(g.gravity_priors()), g.last_solve_ms());
      if (g.landmarks() > 0) {
        std::printf("object landmarks   %llu objects seen in %llu keyframe views\n",
                    static_cast<unsigned long long>(g.landmarks()),
                    static_cast<unsigned long long>(g.landmark_views()));
      }
      std::printf("map moved          in %.0f ms, %llu chunks; mapping paused at most %.0f ms "
                  "(%.0f ms since start)\n",
                  g.last_apply_ms(), static_cast<unsigned long long>(g.last_apply_chunks()),
                  g.last_apply_longest_hold_ms(), g.longest_hold_ms());
    }
  }
  for (const loci::v1::SessionAlignment& s : resp.session_alignments()) {
    const auto& t = s.t_map_odom().t_m();
    if (s.aligned()) {
      std::printf("session %-24s %-12s aligned, odometry origin at (%.3f, %.3f, %.3f) m, %llu kf\n",
                  s.session_id().substr(0, 24).c_str(), s.robot().c_str(), t.x(), t.y(), t.z(),
                  static_cast<unsigned long long>(s.keyframes()));
    } else {
      const std::string joined =
          s.island().empty() || s.island() == s.session_id() ? "" : " of " + s.island();
      std::printf("session %-24s %-12s island%s (not aligned yet), %llu kf, %llu objects in its "
                  "own frame",
                  s.session_id().substr(0, 24).c_str(), s.robot().c_str(), joined.c_str(),
                  static_cast<unsigned long long>(s.keyframes()),
                  static_cast<unsigned long long>(s.island_objects()));
      if (s.island_optimizations() > 0) {
        std::printf(", its pose graph solved %llu times (last: %llu loops kept, %llu rejected)",
                    static_cast<unsigned long long>(s.island_optimizations()),
                    static_cast<unsigned long long>(s.island_loops_accepted()),
                    static_cast<unsigned long long>(s.island_loops_rejected()));
      }
      std::printf("\n");
    }
  }
}

int RunStats(const ServerArgs& a) {
  loci::v1::GetStatsResponse resp;
  if (std::optional<int> done =
          CallQuery(a, &loci::v1::Query::Stub::GetStats, loci::v1::GetStatsRequest(), &resp)) {
    return *done;
  }
  std::printf("sessions           %llu\n", static_cast<unsigned long long>(resp.sessions()));
  std::printf("keyframes          %llu\n", static_cast<unsigned long long>(resp.keyframes()));
  std::printf("objects            %llu (%llu confirmed)\n",
              static_cast<unsigned long long>(resp.objects()),
              static_cast<unsigned long long>(resp.confirmed_objects()));
  std::printf("cloud points       %llu\n", static_cast<unsigned long long>(resp.cloud_points()));
  std::printf(
      "octomap nodes      %llu (%llu scans queued); rebuilt after %llu pose updates, "
      "%llu others within tolerance\n",
      static_cast<unsigned long long>(resp.octomap_nodes()),
      static_cast<unsigned long long>(resp.octomap_pending_scans()),
      static_cast<unsigned long long>(resp.octomap_rebuilds()),
      static_cast<unsigned long long>(resp.octomap_rebuilds_skipped()));
  std::printf("database           %.1f MB\n", resp.db_bytes() / 1e6);
  std::printf("raw per keyframe   %.1f KB (%llu keyframes keep their images)\n",
              resp.raw_bytes_per_keyframe() / 1e3,
              static_cast<unsigned long long>(resp.keyframes_with_raw()));
  std::printf("products per kf    %.1f KB (%llu keyframes)\n",
              resp.product_bytes_per_keyframe() / 1e3,
              static_cast<unsigned long long>(resp.keyframes_with_products()));
  std::printf("place features     %.1f KB per keyframe (%llu keyframes)\n",
              resp.place_feature_bytes_per_keyframe() / 1e3,
              static_cast<unsigned long long>(resp.keyframes_with_place_features()));
  std::printf("checkpoint         %.1f MB (%llu written since start)\n",
              resp.checkpoint_bytes() / 1e6,
              static_cast<unsigned long long>(resp.checkpoints_written()));
  std::printf("queue depth        %llu\n", static_cast<unsigned long long>(resp.queue_depth()));
  std::printf("mapping per kf     %.1f ms; the worker waited at most %.0f ms for the mapping lock\n",
              resp.ingest_ms_mean(), resp.worker_longest_wait_ms());
  PrintAlignment(resp);
  return 0;
}

}  // namespace

void RegisterObjectsCommands(CLI::App& app) {
  auto oa = std::make_shared<ObjectsArgs>();
  CLI::App* o = app.add_subcommand("objects", "list the objects of a running loci-server");
  AddServerOptions(o, oa.get());
  o->add_option("--class", oa->classes, "only these classes (repeatable)");
  o->add_option("--min-confidence", oa->min_confidence, "smallest class confidence [0, 1]");
  o->add_flag("--confirmed", oa->confirmed_only, "confirmed objects only");
  o->callback([oa] { ExitCode() = RunObjects(*oa); });

  auto sa = std::make_shared<ServerArgs>();
  CLI::App* s = app.add_subcommand("stats", "counters of a running loci-server");
  AddServerOptions(s, sa.get());
  s->callback([sa] { ExitCode() = RunStats(*sa); });
}

}  // namespace loci::cli
