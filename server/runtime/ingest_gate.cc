#include "server/runtime/ingest_gate.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <regex>

#include "common/time.h"
#include "server/runtime/keyframe_decoder.h"
#include "server/runtime/proto_convert.h"

namespace loci::server {
namespace {

constexpr char kServerVersion[] = "loci-server 0.1.0";

// A new session's record from the request; INVALID_ARGUMENT for bad intrinsics or depth scale.
StatusOr<SessionRecord> NewSession(const loci::v1::OpenSessionRequest& req,
                                   const ServerOptions& options) {
  SessionRecord s;
  s.robot_name = req.robot_name();
  s.client_version = req.client_version();
  const auto& k = req.intrinsics();
  s.camera = {k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width_px()),
              static_cast<int>(k.height_px())};
  if (Status st = s.camera.Validate(); !st.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics: ", st.message()));
  }
  s.depth_scale = req.depth_scale();
  if (!std::isfinite(s.depth_scale) || s.depth_scale <= 0 || s.depth_scale > 1e6) {
    return absl::InvalidArgumentError("depth_scale must be in (0, 1e6]");
  }
  if (auto it = options.T_base_odom.find(s.robot_name); it != options.T_base_odom.end()) {
    s.T_base_odom = it->second;
  } else {
    // Placed by place recognition (server/align/), or the map's origin if its first keyframe
    // is the map's first.
    s.aligned = !options.align.enabled;
  }
  s.opened_ns = NowNs();
  return s;
}

}  // namespace

loci::v1::KeyframeAck MakeAck(int64_t seq, const Status& status) {
  loci::v1::KeyframeAck ack;
  ack.set_seq(seq);
  ToProto(status, ack.mutable_status());
  return ack;
}

StatusOr<loci::v1::OpenSessionResponse> IngestGate::OpenSession(
    const loci::v1::OpenSessionRequest& req) {
  static const std::regex kRobotName("[A-Za-z0-9_.-]{1,64}");
  if (!std::regex_match(req.robot_name(), kRobotName)) {
    return absl::InvalidArgumentError(
        absl::StrCat("robot_name '", req.robot_name(), "' must match [A-Za-z0-9_.-]{1,64}"));
  }
  if (!req.site().empty() && req.site() != options_.site) {
    return absl::FailedPreconditionError(absl::StrCat(
        "this server maps site '", options_.site, "', not '", req.site(),
        "': connect to that site's server"));
  }
  loci::v1::OpenSessionResponse resp;
  resp.set_server_version(kServerVersion);
  if (req.resume()) {
    LOCI_ASSIGN_OR_RETURN(std::optional<SessionRecord> s,
                          store_->LatestOpenSession(req.robot_name()));
    if (s) {
      LOCI_ASSIGN_OR_RETURN(int64_t last, store_->LastStoredSeq(s->row_id));
      resp.set_session_id(s->session_id);
      resp.set_last_stored_seq(last);
      sessions_->Put(*s);
      return resp;
    }
  }
  LOCI_ASSIGN_OR_RETURN(SessionRecord s, NewSession(req, options_));
  LOCI_ASSIGN_OR_RETURN(s, store_->CreateSession(s));
  resp.set_session_id(s.session_id);
  resp.set_last_stored_seq(-1);
  sessions_->Put(s);
  spdlog::info("session {} opened for robot {}", s.session_id, s.robot_name);
  return resp;
}

StatusOr<loci::v1::CloseSessionResponse> IngestGate::CloseSession(
    const loci::v1::CloseSessionRequest& req, const std::string* only_robot) {
  LOCI_ASSIGN_OR_RETURN(SessionRecord s, sessions_->Find(req.session_id(), only_robot));
  LOCI_RETURN_IF_ERROR(store_->CloseSession(s.row_id, NowNs()));
  sessions_->MarkClosed(s.session_id);
  LOCI_ASSIGN_OR_RETURN(uint64_t n, store_->CountKeyframes(s.row_id));
  loci::v1::CloseSessionResponse resp;
  resp.set_keyframes_stored(n);
  return resp;
}

IngestGate::Admitted IngestGate::Admit(const loci::v1::Keyframe& kf,
                                       const std::string* only_robot) {
  auto session = sessions_->Find(kf.session_id(), only_robot);
  if (!session.ok()) return {MakeAck(kf.seq(), session.status()), std::nullopt, {}};
  if (!session->open) {
    return {MakeAck(kf.seq(), absl::FailedPreconditionError(
                                  absl::StrCat("session ", kf.session_id(), " is closed"))),
            std::nullopt, {}};
  }
  MapperKeyframe decoded;
  const double cpu0 = ThreadCpuMs();
  auto record = Validate(kf, *session, &decoded);
  const double validate_ms = ThreadCpuMs() - cpu0;
  if (!record.ok()) {
    spdlog::warn("keyframe {} of {} rejected: {}", kf.seq(), kf.session_id(),
                 record.status().ToString());
    return {MakeAck(kf.seq(), record.status()), std::nullopt, {}};
  }
  return Store(kf, *record, validate_ms, std::move(decoded));
}

IngestGate::Admitted IngestGate::Store(const loci::v1::Keyframe& kf, const KeyframeRecord& record,
                                       double validate_ms, MapperKeyframe decoded) {
  const auto t0 = std::chrono::steady_clock::now();  // the wait for the order lock included
  Admitted out{{}, std::nullopt, std::unique_lock<std::mutex>(order_mu_)};
  auto inserted = store_->InsertKeyframe(record);
  times_->AddAccepted(validate_ms, MsSince(t0));
  if (!inserted.ok()) {
    spdlog::error("keyframe {} of {} not stored: {}", kf.seq(), kf.session_id(),
                  inserted.status().ToString());
    out.ack = MakeAck(kf.seq(), absl::UnavailableError(absl::StrCat(
                                    "storage failed: ", inserted.status().message())));
    return out;
  }
  if (inserted->conflict) {
    out.ack = MakeAck(kf.seq(), absl::AlreadyExistsError(absl::StrCat(
                                    "seq ", kf.seq(), " of ", kf.session_id(),
                                    " is already stored with a different stamp, pose or images; "
                                    "kept the stored one")));
    out.ack.set_keyframe_id(inserted->keyframe_id);
    out.ack.set_duplicate(true);
    return out;
  }
  out.ack = MakeAck(kf.seq(), absl::OkStatus());
  out.ack.set_keyframe_id(inserted->keyframe_id);
  out.ack.set_duplicate(inserted->duplicate);
  if (!inserted->duplicate) {
    sessions_->NoteStored(record);
    decoded.keyframe_id = inserted->keyframe_id;
    out.keyframe = std::move(decoded);
  }
  return out;
}

StatusOr<KeyframeRecord> IngestGate::Validate(const loci::v1::Keyframe& kf,
                                              const SessionRecord& session,
                                              MapperKeyframe* decoded) {
  ValidationLimits limits;
  limits.max_detections = options_.max_detections;
  limits.max_image_px = options_.max_image_px;
  limits.map_extent_m = options_.map_extent_m;
  limits.max_future_ns = SecondsToNs(options_.max_future_s);
  decode_slots_.acquire();
  auto record = ValidateKeyframe(kf, session, limits, decoded);
  decode_slots_.release();
  if (!record.ok()) return record;
  LOCI_RETURN_IF_ERROR(sessions_->CheckStampOrder(*record, options_.stamp_backwards_ms));
  return record;
}

}  // namespace loci::server
