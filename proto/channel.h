// Client channels to loci-server: plaintext or TLS, with a bearer token sent on every call
// (`authorization: Bearer TOKEN` metadata, added by a client interceptor so that it also
// travels over plaintext loopback channels, where gRPC refuses call credentials).
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/support/channel_arguments.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "common/status.h"

namespace loci {

struct ChannelSecurity {
  std::string token{};            // bearer token; "" = none
  std::string tls_ca_file{};      // PEM CA that signed the server's certificate; "" = plaintext
  std::string tls_cert_file{};    // client certificate (PEM) for mutual TLS; "" = none
  std::string tls_key_file{};     // its private key
  std::string tls_server_name{};  // name to verify the certificate against; "" = the host

  // token from $LOCI_TOKEN and tls_ca_file from $LOCI_TLS_CA where they are empty.
  ChannelSecurity WithEnvironment() const;
};

// A channel to `address` (HOST:PORT). NotFound / InvalidArgument for unreadable TLS files.
StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(
    const std::string& address, const ChannelSecurity& security,
    const grpc::ChannelArguments& args = grpc::ChannelArguments());

// Waits until the server behind `channel` reports SERVING on the gRPC health service (it opens
// its port at once and reports NOT_SERVING while it loads its map), asking every 0.5 s;
// `on_wait` (optional) is called about every 2 s with the seconds waited and the last status.
// OK at once for a server without the health service; UNAVAILABLE at the deadline.
Status WaitForServing(grpc::Channel& channel, std::chrono::system_clock::time_point deadline,
                      const std::function<void(double, const std::string&)>& on_wait = nullptr);

}  // namespace loci
