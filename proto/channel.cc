#include "proto/channel.h"

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/client_interceptor.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

#include "common/image_codec.h"  // ReadFileBytes
#include "grpc/health/v1/health.grpc.pb.h"

namespace loci {
namespace {

namespace gx = grpc::experimental;

class BearerInterceptor : public gx::Interceptor {
 public:
  explicit BearerInterceptor(const std::string* header) : header_(header) {}
  void Intercept(gx::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            gx::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->insert({"authorization", *header_});
    }
    methods->Proceed();
  }

 private:
  const std::string* header_;
};

class BearerInterceptorFactory : public gx::ClientInterceptorFactoryInterface {
 public:
  explicit BearerInterceptorFactory(const std::string& token) : header_("Bearer " + token) {}
  gx::Interceptor* CreateClientInterceptor(gx::ClientRpcInfo*) override {
    return new BearerInterceptor(&header_);
  }

 private:
  const std::string header_;
};

StatusOr<std::shared_ptr<grpc::ChannelCredentials>> Credentials(const ChannelSecurity& s) {
  if (s.tls_ca_file.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  LOCI_ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadFileBytes(s.tls_ca_file));
  if (!s.tls_cert_file.empty()) {
    LOCI_ASSIGN_OR_RETURN(ssl.pem_cert_chain, ReadFileBytes(s.tls_cert_file));
    LOCI_ASSIGN_OR_RETURN(ssl.pem_private_key, ReadFileBytes(s.tls_key_file));
  }
  return grpc::SslCredentials(ssl);
}

}  // namespace

ChannelSecurity ChannelSecurity::WithEnvironment() const {
  ChannelSecurity s = *this;
  if (const char* t = std::getenv("LOCI_TOKEN"); s.token.empty() && t != nullptr) s.token = t;
  if (const char* ca = std::getenv("LOCI_TLS_CA"); s.tls_ca_file.empty() && ca != nullptr) {
    s.tls_ca_file = ca;
  }
  return s;
}

StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(const std::string& address,
                                                     const ChannelSecurity& security,
                                                     const grpc::ChannelArguments& base_args) {
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<grpc::ChannelCredentials> credentials,
                        Credentials(security));
  grpc::ChannelArguments args = base_args;
  if (!security.tls_server_name.empty()) {
    args.SetSslTargetNameOverride(security.tls_server_name);
  }
  std::vector<std::unique_ptr<gx::ClientInterceptorFactoryInterface>> interceptors;
  if (!security.token.empty()) {
    interceptors.push_back(std::make_unique<BearerInterceptorFactory>(security.token));
  }
  return gx::CreateCustomChannelWithInterceptors(address, credentials, args,
                                                 std::move(interceptors));
}

}  // namespace loci

namespace loci {

Status WaitForServing(grpc::Channel& channel, std::chrono::system_clock::time_point deadline,
                      const std::function<void(double, const std::string&)>& on_wait) {
  using Clock = std::chrono::system_clock;  // gRPC deadlines
  auto stub = grpc::health::v1::Health::NewStub(
      std::shared_ptr<grpc::Channel>(&channel, [](grpc::Channel*) {}));
  const auto t0 = Clock::now();
  auto next_note = t0 + std::chrono::seconds(2);
  std::string last = "no answer";
  for (auto now = Clock::now(); now < deadline; now = Clock::now()) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::min(deadline, now + std::chrono::seconds(2)));
    ctx.set_wait_for_ready(true);  // a server still binding its port is waited for, not failed
    grpc::health::v1::HealthCheckRequest req;
    grpc::health::v1::HealthCheckResponse resp;
    const grpc::Status s = stub->Check(&ctx, req, &resp);
    if (s.ok() && resp.status() == grpc::health::v1::HealthCheckResponse::SERVING) {
      return absl::OkStatus();
    }
    if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED) return absl::OkStatus();
    last = s.ok() ? grpc::health::v1::HealthCheckResponse::ServingStatus_Name(resp.status())
                  : s.error_message();
    now = Clock::now();
    if (on_wait && now >= next_note) {
      on_wait(std::chrono::duration<double>(now - t0).count(), last);
      next_note = now + std::chrono::seconds(2);
    }
    const auto next = now + std::chrono::milliseconds(500);
    if (next >= deadline) break;
    std::this_thread::sleep_until(next);
  }
  return absl::UnavailableError(absl::StrCat(
      "loci-server not SERVING after ",
      static_cast<int>(std::chrono::duration<double>(Clock::now() - t0).count()), " s (health: ",
      last, ")"));
}

}  // namespace loci
