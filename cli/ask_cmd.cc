// `loci ask "QUESTION" [--server HOST:PORT] [--robot NAME] [--json]`: asks a running
// loci-server (gRPC Query.Ask) and prints the answer sentence with the matching objects, or the
// AskResponse as proto JSON (the same JSON as GET /api/ask). A question the server cannot take
// fails the call (INVALID_ARGUMENT): the message on stderr, or the HTTP API's error JSON with
// --json; exit code 1.
#include <cstdio>
#include <string>

#include "cli/commands.h"
#include "cli/query_client.h"

namespace loci::cli {
namespace {

struct AskArgs : ServerArgs {
  std::string question;
  std::string robot;
};

int RunAsk(const AskArgs& a) {
  loci::v1::AskRequest req;
  req.set_text(a.question);
  req.set_robot_name(a.robot);
  loci::v1::AskResponse resp;
  if (std::optional<int> done = CallQuery(a, &loci::v1::Query::Stub::Ask, req, &resp)) {
    return *done;
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
  AddServerOptions(c, args.get());
  c->add_option("--robot", args->robot, "viewpoint robot for left/right/front/behind");
  c->callback([args] { ExitCode() = RunAsk(*args); });
}

}  // namespace loci::cli
