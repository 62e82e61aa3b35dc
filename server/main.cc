// `loci-server`: the loci mapping server (gRPC Mapping + Query services, SQLite persistence).
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>

#include "common/config.h"
#include "common/malloc_tuning.h"
#include "query/query_options.h"
#include "server/http/http_api.h"
#include "server/http/viewer_files.h"
#include "server/service/grpc_server.h"
#include "server/service/map_server.h"
#include "server/service/query_adapter.h"
#include "server/service/server_detector.h"

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

}  // namespace

int main(int argc, char** argv) {
  loci::LimitHeapArenas();  // before any thread (common/malloc_tuning.h)
  CLI::App app{"loci-server: semantic map server for robot fleets"};
  std::string config_path, listen, db, http, query_config, viewer_dir, log_level = "info";
  bool strict_config = false;
  std::string token_file;
  loci::server::TlsFiles tls;
  app.add_option("--config", config_path, "YAML config (see config/server.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--listen", listen, "gRPC address HOST:PORT [127.0.0.1:50051]");
  app.add_option("--db", db, "SQLite database file [./loci.db]");
  app.add_option("--http", http, "HTTP/JSON API address HOST:PORT or off [off]");
  app.add_option("--viewer-dir", viewer_dir,
                 "web viewer files served at http://HOST:PORT/ (off = none) [$LOCI_HOME/viewer, "
                 "else ../share/loci/viewer beside this binary]");
  app.add_option("--query-config", query_config,
                 "query engine YAML (see config/query.yaml) [built-in defaults]")
      ->check(CLI::ExistingFile);
  app.add_option("--token-file", token_file,
                 "bearer tokens, one `TOKEN ROLE` per line (roles: admin, query, robot:NAME); "
                 "without it only loopback addresses are served")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-cert", tls.cert_file, "TLS certificate chain (PEM) for gRPC and HTTP")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", tls.key_file, "TLS private key (PEM)")->check(CLI::ExistingFile);
  app.add_option("--tls-client-ca", tls.client_ca_file,
                 "require client certificates signed by this CA (mutual TLS)")
      ->check(CLI::ExistingFile);
  app.add_flag("--strict-config", strict_config,
               "unknown keys in the YAML files are errors (default: warnings)");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  loci::SetStrictConfig(strict_config);
  // Logs go to stderr: stdout carries only the "listening on HOST:PORT" line for scripts.
  spdlog::set_default_logger(spdlog::stderr_color_mt("loci-server"));
  spdlog::set_level(spdlog::level::from_str(log_level));

  loci::server::ServerOptions options;
  loci::Status st = config_path.empty() ? options.LoadClasses() : options.FromYamlFile(config_path);
  if (!st.ok()) {
    std::cerr << "error: " << st.message() << "\n";
    return 2;
  }
  if (!listen.empty()) options.listen = listen;
  if (!db.empty()) options.db_path = db;
  if (!http.empty()) options.http = http;
  if (tls.cert_file.empty() != tls.key_file.empty()) {
    std::cerr << "error: --tls-cert and --tls-key go together\n";
    return 2;
  }
  loci::server::Authorizer auth;
  if (!token_file.empty()) {
    auto a = loci::server::Authorizer::FromFile(token_file);
    if (!a.ok()) {
      std::cerr << "error: " << a.status().message() << "\n";
      return 2;
    }
    auth = std::move(*a);
  }
  if (loci::Status exposure = CheckExposure(options, auth); !exposure.ok()) {
    std::cerr << "error: " << exposure.message() << "\n";
    return 2;
  }
  loci::server::QueryAdapterOptions query_options;
  if (!query_config.empty()) {
    auto q = loci::query::LoadQueryOptions(query_config);
    if (!q.ok()) {
      std::cerr << "error: " << q.status().message() << "\n";
      return 2;
    }
    query_options.query = std::move(*q);
  }
  loci::server::UseMapClassPriors(options.map, &query_options);

  // SIGINT/SIGTERM are handled by sigwait below; block them before any thread starts.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto detector = loci::server::MakeServerDetector(options, config_path);
  if (!detector.ok()) {
    std::cerr << "error: " << detector.status().message() << "\n";
    return 2;
  }
  // The port opens at once; the map loads behind it (health NOT_SERVING until it is in).
  auto server = loci::server::MapServer::OpenAsync(options, nullptr, *detector);
  if (!server.ok()) {
    std::cerr << "error: " << server.status().message() << "\n";
    return 1;
  }
  auto grpc = loci::server::GrpcServer::Start(
      server->get(), options.listen, options.max_message_mb,
      std::make_shared<loci::server::QueryAdapter>(std::move(query_options)), auth, tls);
  if (!grpc.ok()) {
    std::cerr << "error: " << grpc.status().message() << "\n";
    return 1;
  }
  std::unique_ptr<loci::server::HttpApi> http_api;
  std::string viewer_served;
  if (options.http != "off") {
    const loci::server::HttpOptions http_options{
        .viewer_dir = ViewerDir(viewer_dir), .max_event_clients = options.max_event_clients};
    viewer_served = http_options.viewer_dir;
    auto h = loci::server::HttpApi::Start(&(*grpc)->query_service(), options.http,
                                          &(*grpc)->auth(), tls, http_options);
    if (!h.ok()) {
      std::cerr << "error: " << h.status().message() << "\n";
      return 1;
    }
    http_api = std::move(*h);
  }
  const std::string host = options.listen.substr(0, options.listen.rfind(':'));
  // The bound port on stdout lets scripts and tests start the server on port 0.
  std::cout << "listening on " << host << ":" << (*grpc)->port() << std::endl;
  if (http_api) {
    const std::string http_host = options.http.substr(0, options.http.rfind(':'));
    std::cout << "http on " << http_host << ":" << http_api->port() << std::endl;
    if (!viewer_served.empty()) {
      spdlog::info("web viewer: http://{}:{}/ (files from {})", http_host, http_api->port(),
                   viewer_served);
    }
  }
  spdlog::info("loci-server: db {}; loading the map", options.db_path);

  int sig = 0;
  sigwait(&signals, &sig);
  spdlog::info("signal {}: shutting down", sig);
  if (http_api) http_api->Shutdown();
  (*grpc)->Shutdown();
  (*server)->Flush();
  grpc->reset();
  server->reset();
  return 0;
}
