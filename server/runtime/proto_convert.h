// Conversions between the server's types and protocol v1 messages.
#pragma once

#include "common/map_object.h"
#include "common/se3.h"
#include "common/status.h"
#include "loci/v1/types.pb.h"
#include "proto/convert.h"
#include "server/map/fused_object.h"
#include "server/map/semantic_cloud.h"

namespace loci::server {

// Pose, vector and detection conversions shared with the client (proto/convert.h).
using loci::ToProto;

void ToProto(const MapObject& in, loci::v1::Object* out);
void ToProto(const SemanticPoint& in, loci::v1::CloudPoint* out);
void ToProto(const ColoredPoint& in, int64_t object_id, loci::v1::CloudPoint* out);
void ToProto(const Status& in, loci::v1::Status* out);
// Back from the wire (clients, `loci eval objects --server`).
MapObject FromProto(const loci::v1::Object& in);

}  // namespace loci::server
