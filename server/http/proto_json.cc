#include "server/http/proto_json.h"

#include <google/protobuf/util/json_util.h>

#include <nlohmann/json.hpp>

namespace loci::server {

std::string ProtoToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.add_whitespace = false;
  std::string out;
  if (!google::protobuf::util::MessageToJsonString(message, &out, options).ok()) return "{}";
  return out;
}

std::string ErrorJson(const std::string& code_name, const std::string& message) {
  nlohmann::json j;
  j["error"]["code"] = code_name;
  j["error"]["message"] = message;
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace loci::server
