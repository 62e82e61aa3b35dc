// `loci ask "QUESTION" [--server HOST:PORT] [--robot NAME] [--json]`: asks a running
// loci-server (gRPC Query.Ask) and prints the answer sentence with the matching objects, or the
// AskResponse as proto JSON (the same JSON as GET /api/ask). A question the server cannot take
// fails the call (INVALID_ARGUMENT): the message on stderr, or the HTTP API's error JSON with
// --json; exit code 1.
#include <cstdio>
#include <string>

#include "cli/commands.h"
#include "cli/query_client.h"
#include "proto/json.h"

namespace loci::cli {
namespace {

struct AskArgs {
  std::string question;
  std::string server = "127.0.0.1:50051";
  std::string robot;
  bool json = false;
  double timeout_s = 10.0;
  ChannelSecurity security;
};

int RunAsk(const AskArgs& a) {
  auto stub = ConnectQuery(a.server, a.security);
  if (!stub.ok()) {
    std::fprintf(stderr, "error: %s\n", std::string(stub.status().message()).c_str());
    return 2;
  }
  grpc::ClientContext ctx;
  SetDeadline(&ctx, a.timeout_s);
  loci::v1::AskRequest req;
  req.set_text(a.question);
  req.set_robot_name(a.robot);
  loci::v1::AskResponse resp;
  const grpc::Status s = (*stub)->Ask(&ctx, req, &resp);
  if (!s.ok()) return ReportFailure(a.server, s, a.json);
  if (a.json) {
    std::printf("%s\n", ProtoToJson(resp).c_str());
    return 0;
  }
  std::printf("%s\n", resp.answer().c_str());
  for (const auto& o : resp.objects()) {
    std::printf("  #%lld %s (%.2f) at (%.2f, %.2f, %.2f) m\n", static_cast<long long>(o.id()),
                o.class_name().c_str(), o.confidence(), o.centroid_m().x(), o.centroid_m().y(),
                o.centroid_m().z());
  }
  for (const auto& r : resp.relations()) {
    std::printf("  %s #%lld -> #%lld (%.2f): %s\n", r.name().c_str(),
                static_cast<long long>(r.subject_id()), static_cast<long long>(r.anchor_id()),
                r.confidence(), r.evidence().c_str());
  }
  return 0;
}

}  // namespace

void RegisterAskCommand(CLI::App& app) {
  auto args = std::make_shared<AskArgs>();
  CLI::App* c = app.add_subcommand("ask", "ask a running loci-server a question about the map");
  c->add_option("question", args->question, "e.g. \"where is the book on the table\"")->required();
  c->add_option("--server", args->server, "gRPC address HOST:PORT")->capture_default_str();
  AddSecurityOptions(c, &args->security);
  c->add_option("--robot", args->robot, "viewpoint robot for left/right/front/behind");
  c->add_flag("--json", args->json, "print the AskResponse as JSON");
  c->add_option("--timeout", args->timeout_s, "seconds to wait for the answer")
      ->capture_default_str();
  c->callback([args] { ExitCode() = RunAsk(*args); });
}

}  // namespace loci::cli
