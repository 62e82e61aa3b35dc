// `loci-server`: the loci mapping server (gRPC Mapping + Query services; the map in SQLite or,
// shared by several servers, in PostgreSQL).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <unistd.h>

#include <csignal>
#include <iostream>

#include "common/config.h"
#include "common/malloc_tuning.h"
#include "query/query_options.h"
#include "server/http/http_api.h"
#include "server/http/viewer_files.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/runtime/replica_map.h"
#include "server/service/query_adapter.h"
#include "server/runtime/server_detector.h"
#include "server/runtime/store_opener.h"

namespace {

// Without tokens every caller is admin: refuse to serve anything but loopback.
loci::Status CheckExposure(const loci::server::ServerOptions& options,
                           const loci::server::Authorizer& auth) {
  if (auth.enabled()) return loci::Status();
  for (const std::string& address : {options.listen, options.http}) {
    if (address == "off") continue;
    const std::string host = address.substr(0, address.rfind(':'));
    if (!loci::server::IsLoopback(host)) {
      return absl::FailedPreconditionError(
          "refusing to listen on " + address +
          " without authentication: pass --token-file FILE (lines `TOKEN ROLE`, see "
          "docs/security.md) or bind 127.0.0.1");
    }
  }
  return loci::Status();
}

// The viewer folder to serve: the flag's ("off": none), else the default one when it is there.
std::string ViewerDir(const std::string& flag) {
  if (flag == "off") return "";
  if (!flag.empty()) return flag;
  const std::string dir = loci::server::DefaultViewerDir();
  if (loci::server::HasViewer(dir)) return dir;
  spdlog::warn("no web viewer at {} (build the loci_viewer target or pass --viewer-dir); / is 404",
               dir);
  return "";
}

// The command line.
struct Flags {
  std::string config_path, listen, db, store, site, http, query_config, viewer_dir,
      log_level = "info";
  bool strict_config = false, print_options = false, read_only = false;
  std::string token_file, detector_config;
  loci::server::TlsFiles tls;
};

void AddFlags(CLI::App* app, Flags* f) {
  app->add_option("--config", f->config_path, "YAML config (see config/server.yaml)")
      ->check(CLI::ExistingFile);
  app->add_option("--listen", f->listen, "gRPC address HOST:PORT [127.0.0.1:50051]");
  app->add_option("--db", f->db, "SQLite database file [./loci.db]");
  app->add_option("--store", f->store,
                  "the map store: sqlite:FILE, or postgresql://USER@HOST:PORT/DB shared by "
                  "several servers (one writer per site; a second one waits as a standby) "
                  "[SQLite at --db]");
  app->add_option("--site", f->site,
                  "the site (map) to serve in a PostgreSQL store, [a-z0-9_-]{1,40} [default]");
  app->add_flag("--read-only", f->read_only,
                "serve queries on the map the site's writer publishes (PostgreSQL store), "
                "reloaded on each publication; robots are sent to the writer");
  app->add_option("--http", f->http, "HTTP/JSON API address HOST:PORT or off [off]");
  app->add_option("--viewer-dir", f->viewer_dir,
                  "web viewer files served at http://HOST:PORT/ (off = none) [$LOCI_HOME/viewer, "
                  "else ../share/loci/viewer beside this binary]");
  app->add_option("--detector", f->detector_config,
                  "YAML with a `detector:` section replacing the config's (server-side "
                  "detection, e.g. config/server-detector.yaml)")
      ->check(CLI::ExistingFile);
  app->add_option("--query-config", f->query_config,
                  "query engine YAML (see config/query.yaml) [built-in defaults]")
      ->check(CLI::ExistingFile);
  app->add_option("--token-file", f->token_file,
                  "bearer tokens, one `TOKEN ROLE` per line (roles: admin, query, robot:NAME); "
                  "without it only loopback addresses are served")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", f->tls.cert_file, "TLS certificate chain (PEM) for gRPC and HTTP")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-key", f->tls.key_file, "TLS private key (PEM)")->check(CLI::ExistingFile);
  app->add_option("--tls-client-ca", f->tls.client_ca_file,
                  "require client certificates signed by this CA (mutual TLS)")
      ->check(CLI::ExistingFile);
  app->add_flag("--print-options", f->print_options,
                "print the map options with their defaults and doc lines, and exit");
  app->add_flag("--strict-config", f->strict_config,
                "unknown keys in the YAML files are errors (default: warnings)");
  app->add_option("--log-level", f->log_level, "trace|debug|info|warn|error")
      ->capture_default_str();
}

// What the flags and the config files say the server is.
struct Setup {
  loci::server::ServerOptions options;
  loci::server::Authorizer auth;
  loci::server::QueryAdapterOptions query_options;
};

loci::StatusOr<Setup> ReadSetup(const Flags& f) {
  Setup s;
  LOCI_RETURN_IF_ERROR(f.config_path.empty() ? s.options.LoadClasses()
                                             : s.options.FromYamlFile(f.config_path));
  if (!f.detector_config.empty()) {
    LOCI_RETURN_IF_ERROR(s.options.DetectorFromYamlFile(f.detector_config));
  }
  if (!f.listen.empty()) s.options.listen = f.listen;
  if (!f.db.empty()) s.options.db_path = f.db;
  if (!f.store.empty()) s.options.store = f.store;
  if (!f.site.empty()) s.options.site = f.site;
  if (!f.http.empty()) s.options.http = f.http;
  if (f.tls.cert_file.empty() != f.tls.key_file.empty()) {
    return absl::InvalidArgumentError("--tls-cert and --tls-key go together");
  }
  if (!f.token_file.empty()) {
    LOCI_ASSIGN_OR_RETURN(s.auth, loci::server::Authorizer::FromFile(f.token_file));
  }
  LOCI_RETURN_IF_ERROR(CheckExposure(s.options, s.auth));
  if (!f.query_config.empty()) {
    LOCI_ASSIGN_OR_RETURN(s.query_options.query, loci::query::LoadQueryOptions(f.query_config));
  }
  loci::server::UseMapClassPriors(s.options.map, &s.query_options);
  return s;
}

// SIGINT and SIGTERM, blocked in every thread (block them before any starts) for sigwait.
sigset_t BlockShutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// Whether SIGINT or SIGTERM arrived (they are blocked, so they wait as pending).
bool ShutdownPending() {
  sigset_t pending;
  sigpending(&pending);
  return sigismember(&pending, SIGINT) == 1 || sigismember(&pending, SIGTERM) == 1;
}

// A standby's wait for the site's lease: logged when the holder changes; a signal ends it.
bool StandBy(const loci::server::ServerOptions& options, const loci::server::LeaseHolder& h) {
  static std::string logged;
  const std::string who = h.holder + "@" + std::to_string(h.epoch);
  if (who != logged) {
    spdlog::info(
        "standby: site '{}' is mapped by {} at {} (lease epoch {}, expires in {:.1f} s); "
        "taking over when the lease lapses",
        options.site, h.holder, h.address.empty() ? "?" : h.address, h.epoch, h.expires_in_s);
    logged = who;
  }
  return !ShutdownPending();
}

int Fail(const loci::Status& status, int code) {
  std::cerr << "error: " << status.message() << "\n";
  return code;
}

// Prints the bound ports on stdout (scripts and tests start the server on port 0).
void AnnounceAddresses(const loci::server::ServerOptions& options, int grpc_port,
                       const loci::server::HttpApi* http_api, const std::string& viewer_served) {
  const std::string host = options.listen.substr(0, options.listen.rfind(':'));
  std::cout << "listening on " << host << ":" << grpc_port << std::endl;
  if (http_api == nullptr) return;
  const std::string http_host = options.http.substr(0, options.http.rfind(':'));
  std::cout << "http on " << http_host << ":" << http_api->port() << std::endl;
  if (!viewer_served.empty()) {
    spdlog::info("web viewer: http://{}:{}/ (files from {})", http_host, http_api->port(),
                 viewer_served);
  }
}

// The address the site's writer announced, "" when no server holds its lease.
std::string WriterOf(const loci::server::ServerOptions& options) {
  auto holder = loci::server::SiteLease::Holder(options.store, options.site);
  return holder.ok() && holder->has_value() ? (*holder)->address : "";
}

// The HTTP API and viewer over `grpc`'s Query calls (null with --http off), and the viewer
// folder it serves ("" = none) in *viewer_served.
loci::StatusOr<std::unique_ptr<loci::server::HttpApi>> StartHttp(
    const loci::server::ServerOptions& options, const Flags& flags, loci::server::GrpcServer& grpc,
    std::string* viewer_served) {
  viewer_served->clear();
  if (options.http == "off") return std::unique_ptr<loci::server::HttpApi>();
  const loci::server::HttpOptions http_options{.viewer_dir = ViewerDir(flags.viewer_dir),
                                               .max_event_clients = options.max_event_clients};
  *viewer_served = http_options.viewer_dir;
  return loci::server::HttpApi::Start(grpc.query_service(), options.http, &grpc.auth(), flags.tls,
                                      http_options);
}

// `--read-only`: a query server over the map the site's writer publishes, until a signal.
int ServeReadOnly(Setup& setup, const Flags& flags, const sigset_t& signals) {
  const loci::server::ServerOptions& options = setup.options;
  std::string description;
  auto store = loci::server::OpenReadOnlyStore(options, &description);
  if (!store.ok()) return Fail(store.status(), 1);
  loci::server::ReplicaMap replica(*store, options.max_watchers);
  auto grpc = loci::server::GrpcServer::StartReadOnly(
      &replica, store->get(), options.listen, options.max_message_mb,
      std::make_shared<loci::server::QueryAdapter>(std::move(setup.query_options)),
      [options] { return WriterOf(options); }, setup.auth, flags.tls);
  if (!grpc.ok()) return Fail(grpc.status(), 1);
  std::string viewer_served;
  auto http_api = StartHttp(options, flags, **grpc, &viewer_served);
  if (!http_api.ok()) return Fail(http_api.status(), 1);
  AnnounceAddresses(options, (*grpc)->port(), http_api->get(), viewer_served);
  spdlog::info("loci-server: {}; loading the published map", description);
  int sig = 0;
  sigwait(&signals, &sig);
  spdlog::info("signal {}: shutting down", sig);
  if (*http_api) (*http_api)->Shutdown();
  (*grpc)->Shutdown();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  loci::LimitHeapArenas();  // before any thread (common/malloc_tuning.h)
  CLI::App app{"loci-server: semantic map server for robot fleets"};
  Flags flags;
  AddFlags(&app, &flags);
  CLI11_PARSE(app, argc, argv);
  if (flags.print_options) {
    std::cout << loci::server::MapOptions::DefaultsYaml();
    return 0;
  }
  loci::SetStrictConfig(flags.strict_config);
  // Logs go to stderr: stdout carries only the "listening on HOST:PORT" line for scripts.
  spdlog::set_default_logger(spdlog::stderr_color_mt("loci-server"));
  spdlog::set_level(spdlog::level::from_str(flags.log_level));

  loci::StatusOr<Setup> setup = ReadSetup(flags);
  if (!setup.ok()) return Fail(setup.status(), 2);
  const loci::server::ServerOptions& options = setup->options;
  const sigset_t signals = BlockShutdownSignals();
  if (flags.read_only) return ServeReadOnly(*setup, flags, signals);

  auto detection = loci::server::MakeServerDetection(
      options, flags.detector_config.empty() ? flags.config_path : flags.detector_config);
  if (!detection.ok()) return Fail(detection.status(), 2);
  // The port opens at once; the map loads behind it (health NOT_SERVING until it is in).
  // A writer that loses its site's lease stops at once: another server maps the site now.
  std::atomic<bool> lease_lost{false};
  auto opened = loci::server::OpenServerStore(
      options, [&](const loci::server::LeaseHolder& h) { return StandBy(options, h); },
      [&lease_lost](const loci::Status& s) {
        spdlog::error("{}: stopping, nothing more is written", s.ToString());
        lease_lost = true;
        kill(getpid(), SIGTERM);
      });
  if (!opened.ok()) {
    const bool stopped = opened.status().code() == absl::StatusCode::kCancelled;
    if (stopped) spdlog::info("signal while standing by: shutting down");
    return stopped ? 0 : Fail(opened.status(), 1);
  }
  auto server = loci::server::MapServer::OpenAsync(options, opened->store, *detection);
  if (!server.ok()) return Fail(server.status(), 1);
  auto grpc = loci::server::GrpcServer::Start(
      server->get(), options.listen, options.max_message_mb,
      std::make_shared<loci::server::QueryAdapter>(std::move(setup->query_options)), setup->auth,
      flags.tls);
  if (!grpc.ok()) return Fail(grpc.status(), 1);
  std::string viewer_served;
  auto http = StartHttp(options, flags, **grpc, &viewer_served);
  if (!http.ok()) return Fail(http.status(), 1);
  std::unique_ptr<loci::server::HttpApi> http_api = std::move(*http);
  AnnounceAddresses(options, (*grpc)->port(), http_api.get(), viewer_served);
  spdlog::info("loci-server: {}; loading the map", opened->description);
  if (opened->lease) {
    const std::string host = options.listen.substr(0, options.listen.rfind(':'));
    if (auto s = opened->lease->Announce(host + ":" + std::to_string((*grpc)->port())); !s.ok()) {
      spdlog::warn("{}", s.ToString());
    }
  }

  int sig = 0;
  sigwait(&signals, &sig);
  spdlog::info("signal {}: shutting down", sig);
  if (http_api) http_api->Shutdown();
  (*grpc)->Shutdown();
  (*server)->Flush();
  grpc->reset();
  server->reset();
  opened->lease.reset();  // released: a standby takes over at once
  return lease_lost ? 3 : 0;
}
