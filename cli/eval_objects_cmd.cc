// `loci eval objects --gt objects.json --groundtruth groundtruth.txt (--db FILE | --server H:P)
// [--json]`: the object map against ground truth (cli/report/gt_eval.h): the map frame aligned
// to the ground-truth world with the keyframe trajectory, per-class Hungarian matching,
// precision, recall, F1, the count error (paper 000 eq. 24), centroid errors, and "where is the
// X on the Y" asked through the server's own Ask for every ground-truth X-on-Y pair.
#include <grpcpp/create_channel.h>

#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "cli/query_client.h"
#include "cli/report/gt_eval.h"
#include "common/config.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/convert.h"
#include "server/map/mapper.h"
#include "server/runtime/proto_convert.h"
#include "server/service/query_adapter.h"
#include "server/runtime/replay.h"
#include "server/runtime/server_options.h"
#include "server/storage/sqlite_store.h"

namespace loci::cli {
namespace {

struct EvalObjectsArgs {
  std::string gt, groundtruth, db, server, config, detector;
  std::vector<std::string> classes;
  std::string align = "positions";
  double max_match_m = 0.3;
  double low_tolerance_m = 0.2;
  bool json = false, no_ask = false, all = false;
  ChannelSecurity security;
};

// The map to evaluate and a way to ask it.
struct MapUnderTest {
  std::vector<MapObject> objects;
  std::vector<Trajectory> keyframes;
  std::function<loci::v1::AskResponse(const std::string&)> ask;
  // Owners for the in-process path.
  std::shared_ptr<server::Mapper> mapper;
  std::shared_ptr<server::QueryAdapter> adapter;
  std::shared_ptr<server::MapperSource> source;
};

StatusOr<MapUnderTest> FromDb(const std::string& db, const server::ServerOptions& options,
                               bool confirmed_only) {
  server::SqliteStoreOptions so;
  so.read_only = true;
  LOCI_ASSIGN_OR_RETURN(auto store, server::SqliteStore::Open(db, so));
  MapUnderTest m;
  auto mapper = std::make_unique<server::Mapper>(options.map);
  server::LoadOptions load;
  load.store_products = false;  // read-only
  LOCI_RETURN_IF_ERROR(server::LoadMap(*store, &mapper, nullptr, load).status());
  m.mapper = std::move(mapper);
  m.objects = m.mapper->Snapshot(confirmed_only);
  for (auto& [robot, traj] : m.mapper->Trajectories()) m.keyframes.push_back(traj);
  server::QueryAdapterOptions query;
  server::UseMapClassPriors(options.map, &query);
  m.adapter = std::make_shared<server::QueryAdapter>(std::move(query));
  m.source = std::make_shared<server::MapperSource>(*m.mapper);
  m.ask = [adapter = m.adapter, source = m.source](const std::string& q) {
    loci::v1::AskRequest req;
    req.set_text(q);
    return server::AnswerOrError(adapter->Ask(req, *source));
  };
  return m;
}

StatusOr<MapUnderTest> FromServer(const std::string& address, const ChannelSecurity& security,
                                  bool confirmed_only) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<loci::v1::Query::Stub> stub,
                        ConnectQuery(address, security, args));
  auto deadline = [](grpc::ClientContext* ctx) {
    ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  };
  MapUnderTest m;
  {
    grpc::ClientContext ctx;
    deadline(&ctx);
    loci::v1::FindObjectsRequest req;
    req.set_confirmed_only(confirmed_only);
    loci::v1::FindObjectsResponse resp;
    const grpc::Status s = stub->FindObjects(&ctx, req, &resp);
    if (!s.ok()) return absl::UnavailableError(absl::StrCat(address, ": ", s.error_message()));
    for (const auto& o : resp.objects()) m.objects.push_back(server::FromProto(o));
  }
  {
    grpc::ClientContext ctx;
    deadline(&ctx);
    loci::v1::GetTrajectoriesResponse resp;
    const grpc::Status s = stub->GetTrajectories(&ctx, {}, &resp);
    if (!s.ok()) return absl::UnavailableError(absl::StrCat(address, ": ", s.error_message()));
    for (const auto& t : resp.trajectories()) {
      Trajectory traj;
      for (const auto& p : t.poses()) traj.push_back({p.t_ns(), PoseFromProto(p.t_map_cam())});
      m.keyframes.push_back(std::move(traj));
    }
  }
  m.ask = [stub, deadline](const std::string& q) {
    grpc::ClientContext ctx;
    deadline(&ctx);
    loci::v1::AskRequest req;
    req.set_text(q);
    loci::v1::AskResponse resp;
    const grpc::Status s = stub->Ask(&ctx, req, &resp);
    if (!s.ok()) resp.set_answer(absl::StrCat("(error: ", s.error_message(), ")"));
    return resp;
  };
  return m;
}

nlohmann::json ToJson(const report::GroundTruthEval& e) {
  const server::ObjectEvalResult& r = e.objects;
  nlohmann::json classes = nlohmann::json::array(), matches = nlohmann::json::array(),
                 pairs = nlohmann::json::array(), objects = nlohmann::json::array();
  for (const MapObject& o : e.objects_world) {
    const Eigen::Vector3d extent = o.aabb_max_m - o.aabb_min_m;
    objects.push_back({{"id", o.id},
                       {"class_name", o.class_name},
                       {"centroid_m", {o.centroid_m.x(), o.centroid_m.y(), o.centroid_m.z()}},
                       {"aabb_size_m", {extent.x(), extent.y(), extent.z()}}});
  }
  for (const auto& c : r.classes) {
    classes.push_back({{"class_name", c.class_name}, {"gt", c.gt}, {"gt_low", c.gt_low},
                       {"mapped", c.mapped}, {"tp", c.tp}, {"fp", c.fp}, {"fn", c.fn},
                       {"neutral", c.neutral}});
  }
  for (const auto& m : r.matches) {
    matches.push_back({{"gt_id", m.gt_name}, {"object_id", m.object_id},
                       {"class_name", m.class_name}, {"centroid_error_m", m.centroid_error_m},
                       {"offset_m", {m.offset_m.x(), m.offset_m.y(), m.offset_m.z()}},
                       {"neutral", m.neutral}});
  }
  for (const auto& p : e.on_pairs) {
    pairs.push_back({{"subject", p.gt_subject}, {"support", p.gt_support},
                     {"question", p.question}, {"answer", p.answer},
                     {"subject_id", p.subject_id}, {"support_id", p.support_id},
                     {"right", p.right}});
  }
  return {{"metric", "objects"},
          {"alignment_ate_rmse_m", e.alignment.trans_m.rmse},
          {"alignment_pairs", e.alignment.pairs},
          {"up_error_deg", e.up_error_deg},
          {"up_error_orientation_deg", e.up_error_orientation_deg},
          {"alignment_disagreement_deg", e.alignment_disagreement_deg},
          {"aligned_by_orientations", e.aligned_by_orientations},
          {"radius_m", e.radius_m},
          {"low_tolerance_m", e.low_tolerance_m},
          {"precision", r.precision},
          {"recall", r.recall},
          {"f1", r.f1},
          {"gt_count", r.gt_count},
          {"detected_count", r.detected_count},
          {"count_error", r.count_error},
          {"mean_centroid_error_m", r.mean_centroid_error_m},
          {"median_centroid_error_m", r.median_centroid_error_m},
          {"max_centroid_error_m", r.max_centroid_error_m},
          {"false_positive_ids", r.false_positive_ids},
          {"missed", r.missed_gt_names},
          {"classes", classes},
          {"matches", matches},
          {"on_pairs", pairs},
          {"objects_world", objects},
          {"on_right", e.on_right},
          {"on_share", e.on_share}};
}

int Fail(int code, absl::string_view message) {
  std::cerr << "error: " << message << "\n";
  return code;
}

int RunEvalObjects(const EvalObjectsArgs& a) {
  if (a.db.empty() == a.server.empty()) return Fail(2, "give exactly one of --db and --server");
  auto gt = ReadObjectsJson(a.gt);
  if (!gt.ok()) return Fail(1, gt.status().message());
  auto groundtruth = ReadTumTrajectory(a.groundtruth);
  if (!groundtruth.ok()) return Fail(1, groundtruth.status().message());
  server::ServerOptions options;
  // The server's own map options by default, so a database is rebuilt as the server built it.
  Status st = options.FromYamlFile(a.config.empty() ? SourceDir() + "/config/server.yaml"
                                                    : a.config);
  if (!st.ok()) return Fail(2, st.message());
  // The server's detector section: its boxes shaped the stored products.
  if (!a.detector.empty()) st = options.DetectorFromYamlFile(a.detector);
  if (!st.ok()) return Fail(2, st.message());
  auto map = a.db.empty() ? FromServer(a.server, a.security, !a.all) : FromDb(a.db, options, !a.all);
  if (!map.ok()) return Fail(1, map.status().message());
  report::GroundTruthEvalInput in;
  in.objects = map->objects;
  in.keyframes = map->keyframes;
  in.groundtruth = *groundtruth;
  in.gt = *gt;
  in.options.max_match_m = a.max_match_m;
  in.options.low_tolerance_m = a.low_tolerance_m;
  // Only classes the map keeps can be found: by default the mapped, non-dynamic classes.
  in.options.classes = a.classes;
  if (in.options.classes.empty()) {
    for (const auto& c : options.map.mapped_classes) {
      if (!options.map.IsDynamic(c)) in.options.classes.push_back(c);
    }
  }
  in.align_by_orientations = a.align == "orientations";
  if (!a.no_ask) in.ask = map->ask;
  auto e = report::EvaluateAgainstGroundTruth(in);
  if (!e.ok()) return Fail(1, e.status().message());
  if (a.json) {
    std::cout << ToJson(*e).dump(2) << "\n";
  } else {
    std::cout << report::FormatGroundTruthEval(*e);
  }
  return 0;
}

}  // namespace

void RegisterEvalObjectsCommand(CLI::App& app) {
  CLI::App* eval = EvalGroup(app);
  auto args = std::make_shared<EvalObjectsArgs>();
  CLI::App* c = eval->add_subcommand(
      "objects",
      "Object map vs ground truth: precision, recall, F1, count error (eq. 24), centroid "
      "errors, X-on-Y answers");
  c->add_option("--gt", args->gt, "ground-truth objects (objects.json of loci synth, objects_gt.json)")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--groundtruth", args->groundtruth,
                "groundtruth.txt (TUM): the map is aligned to its world frame with the keyframes")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--db", args->db, "evaluate a loci-server database (rebuilt offline)")
      ->check(CLI::ExistingFile);
  c->add_option("--server", args->server, "evaluate a running server, HOST:PORT");
  AddSecurityOptions(c, &args->security);
  c->add_option("--config", args->config, "server YAML (map options, class lists)")
      ->check(CLI::ExistingFile);
  c->add_option("--detector", args->detector,
                "the server's --detector YAML, when it ran one (its boxes shaped the products)")
      ->check(CLI::ExistingFile);
  c->add_option("--classes", args->classes,
                "classes to evaluate (default: mapped, non-dynamic classes)");
  c->add_option("--radius", args->max_match_m, "matching radius, m")->capture_default_str();
  c->add_option("--low-tolerance", args->low_tolerance_m,
                "extra radius for `low` ground-truth objects (placed to +-0.2 m), m")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  c->add_option("--align", args->align,
                "how the map is aligned to the world: positions (the TUM ATE way) or orientations "
                "(rotation from the camera orientations; for sequences that turn in place)")
      ->check(CLI::IsMember({"positions", "orientations"}))
      ->capture_default_str();
  c->add_flag("--no-ask", args->no_ask, "skip the X-on-Y questions");
  c->add_flag("--all", args->all, "also evaluate unconfirmed candidate objects");
  c->add_flag("--json", args->json, "print JSON");
  c->callback([args] { ExitCode() = RunEvalObjects(*args); });
}

}  // namespace loci::cli
