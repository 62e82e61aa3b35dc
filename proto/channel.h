// Client channels to loci-server: plaintext or TLS, with a bearer token sent on every call
// (`authorization: Bearer TOKEN` metadata, added by a client interceptor so that it also
// travels over plaintext loopback channels, where gRPC refuses call credentials).
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/support/channel_arguments.h>

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

}  // namespace loci
