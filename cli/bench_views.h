// Shared by `loci bench ingest` and `loci bench load`: a rendered synthetic scene as keyframe
// messages, the process's resident memory, and a session request for it.
#pragma once

#include <string>
#include <vector>

#include "common/status.h"
#include "loci/v1/mapping.pb.h"
#include "synth/scene.h"

namespace loci::cli {

// Renders `options` into DIR/scene and loads every frame as a keyframe message (ground-truth
// pose as T_odom_cam, the scene's detections with masks; no session id or seq yet).
StatusOr<std::vector<loci::v1::Keyframe>> RenderViews(const synth::SceneOptions& options,
                                                      const std::string& dir);

// The keyframe for the i-th send of `views` (cycled): stamps move on by one pass per cycle so a
// session's stamps keep increasing.
loci::v1::Keyframe NthKeyframe(const std::vector<loci::v1::Keyframe>& views, int64_t i,
                               const std::string& session_id);

// OpenSession for `robot` with the TUM fr1 camera the synthetic scenes use.
loci::v1::OpenSessionRequest BenchOpenRequest(const std::string& robot, double depth_scale);

// Resident memory of this process, MB.
double RssMb();
// The process's highest RSS so far, MB (getrusage).
double PeakRssMb();
// Bytes allocated and not freed, MB: glibc's mallinfo2 over every arena, mmap'd blocks
// included (0 on other C libraries). Unlike the RSS, free pages the heap keeps do not count.
double LiveHeapMb();

}  // namespace loci::cli
