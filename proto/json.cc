#include "proto/json.h"

#include <google/protobuf/util/json_util.h>

#include <nlohmann/json.hpp>

namespace loci {

std::string ProtoToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.add_whitespace = false;
  std::string out;
  if (!google::protobuf::util::MessageToJsonString(message, &out, options).ok()) return "{}";
  return out;
}

absl::Status JsonToProto(const std::string& json, google::protobuf::Message* message) {
  const auto status = google::protobuf::util::JsonStringToMessage(json, message);
  if (status.ok()) return absl::OkStatus();
  return absl::InvalidArgumentError("not a " + message->GetTypeName() +
                                    " in JSON: " + status.ToString());
}

std::string ErrorJson(const absl::Status& status) {
  nlohmann::json j;
  j["error"]["code"] = absl::StatusCodeToString(status.code());
  j["error"]["message"] = std::string(status.message());
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace loci
