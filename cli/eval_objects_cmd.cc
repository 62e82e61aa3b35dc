// `loci eval objects --gt objects.json (--db FILE | --server HOST:PORT) [--json]`: object-map
// accuracy against ground truth: count error |D - GT| / GT (paper 000 eq. 24), centroid errors
// after matching by class and nearest centroid, false positives and misses.
#include <grpcpp/create_channel.h>

#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/map/mapper.h"
#include "server/map/object_eval.h"
#include "server/service/proto_convert.h"
#include "server/service/replay.h"
#include "server/service/server_options.h"
#include "server/storage/sqlite_store.h"

namespace loci::cli {
namespace {

struct EvalObjectsArgs {
  std::string gt, db, server, config;
  std::vector<std::string> classes;
  double max_match_m = 0.3;
  bool json = false;
};

StatusOr<std::vector<MapObject>> ObjectsFromDb(const EvalObjectsArgs& a,
                                               const server::ServerOptions& options) {
  server::SqliteStoreOptions so;
  so.read_only = true;
  LOCI_ASSIGN_OR_RETURN(auto store, server::SqliteStore::Open(a.db, so));
  server::Mapper mapper(options.map);
  LOCI_RETURN_IF_ERROR(server::ReplayStore(*store, mapper, nullptr).status());
  return mapper.Snapshot(/*confirmed_only=*/true);
}

StatusOr<std::vector<MapObject>> ObjectsFromServer(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  auto stub = loci::v1::Query::NewStub(
      grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  loci::v1::FindObjectsRequest req;
  req.set_confirmed_only(true);
  loci::v1::FindObjectsResponse resp;
  const grpc::Status s = stub->FindObjects(&ctx, req, &resp);
  if (!s.ok()) {
    return absl::UnavailableError(absl::StrCat(address, ": ", s.error_message()));
  }
  std::vector<MapObject> out;
  for (const auto& o : resp.objects()) out.push_back(server::FromProto(o));
  return out;
}

int RunEvalObjects(const EvalObjectsArgs& a) {
  if (a.db.empty() == a.server.empty()) {
    std::cerr << "error: give exactly one of --db and --server\n";
    return 2;
  }
  auto gt = ReadObjectsJson(a.gt);
  if (!gt.ok()) {
    std::cerr << "error: " << gt.status().message() << "\n";
    return 1;
  }
  server::ServerOptions options;
  Status st = a.config.empty() ? options.LoadClasses() : options.FromYamlFile(a.config);
  if (!st.ok()) {
    std::cerr << "error: " << st.message() << "\n";
    return 2;
  }
  auto objects = a.db.empty() ? ObjectsFromServer(a.server) : ObjectsFromDb(a, options);
  if (!objects.ok()) {
    std::cerr << "error: " << objects.status().message() << "\n";
    return 1;
  }
  server::ObjectEvalOptions eo;
  eo.max_match_m = a.max_match_m;
  // Only classes the map keeps can be found: by default the mapped, non-dynamic classes.
  eo.classes = a.classes;
  if (eo.classes.empty()) {
    for (const auto& c : options.map.mapped_classes) {
      if (!options.map.IsDynamic(c)) eo.classes.push_back(c);
    }
  }
  const server::ObjectEvalResult r = server::EvaluateObjects(*objects, *gt, eo);
  if (a.json) {
    nlohmann::json matches = nlohmann::json::array();
    for (const auto& m : r.matches) {
      matches.push_back({{"gt_id", m.gt_id},
                         {"object_id", m.object_id},
                         {"class_name", m.class_name},
                         {"centroid_error_m", m.centroid_error_m}});
    }
    std::cout << nlohmann::json{{"metric", "objects"},
                                {"gt_count", r.gt_count},
                                {"detected_count", r.detected_count},
                                {"count_error", r.count_error},
                                {"mean_centroid_error_m", r.mean_centroid_error_m},
                                {"max_centroid_error_m", r.max_centroid_error_m},
                                {"false_positive_ids", r.false_positive_ids},
                                {"missed_gt_ids", r.missed_gt_ids},
                                {"matches", matches}}
                     .dump(2)
              << "\n";
    return 0;
  }
  std::printf("objects: detected %d, ground truth %d, count error %.1f %%\n", r.detected_count,
              r.gt_count, 100.0 * r.count_error);
  std::printf(
      "matched %zu: centroid error mean %.4f m, max %.4f m; false positives %zu, "
      "misses %zu\n",
      r.matches.size(), r.mean_centroid_error_m, r.max_centroid_error_m,
      r.false_positive_ids.size(), r.missed_gt_ids.size());
  for (const auto& m : r.matches) {
    std::printf("  %-14s gt %3lld -> object %3lld  %.4f m\n", m.class_name.c_str(),
                static_cast<long long>(m.gt_id), static_cast<long long>(m.object_id),
                m.centroid_error_m);
  }
  return 0;
}

}  // namespace

void RegisterEvalObjectsCommand(CLI::App& app) {
  CLI::App* eval = nullptr;
  for (CLI::App* s : app.get_subcommands([](CLI::App* s) { return s->get_name() == "eval"; })) {
    eval = s;
  }
  if (eval == nullptr) {
    eval = app.add_subcommand("eval", "Evaluate trajectories and maps");
    eval->require_subcommand(1);
  }
  auto args = std::make_shared<EvalObjectsArgs>();
  CLI::App* c = eval->add_subcommand(
      "objects", "Object map vs ground truth: count error (eq. 24), centroid errors, FP, misses");
  c->add_option("--gt", args->gt, "ground-truth objects.json (loci synth)")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--db", args->db, "evaluate a loci-server database (rebuilt offline)")
      ->check(CLI::ExistingFile);
  c->add_option("--server", args->server, "evaluate a running server, HOST:PORT");
  c->add_option("--config", args->config, "server YAML (map options, class lists)")
      ->check(CLI::ExistingFile);
  c->add_option("--classes", args->classes,
                "GT classes to evaluate (default: mapped, non-dynamic classes)");
  c->add_option("--max-match", args->max_match_m, "largest centroid distance of a match, m")
      ->capture_default_str();
  c->add_flag("--json", args->json, "print JSON");
  c->callback([args] { ExitCode() = RunEvalObjects(*args); });
}

}  // namespace loci::cli
