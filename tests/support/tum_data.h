// The full TUM sequences some tests use when present (they skip otherwise): $LOCI_DATA/NAME,
// else ../shared/data/NAME beside the source tree. Header-only; needs LOCI_SOURCE_DIR (set for
// every test target) and loci_common.
#pragma once

#include <filesystem>
#include <string>

#include "common/config.h"

namespace loci::testing {

// The folder of sequence `name` (e.g. "tum_fr1_rpy") holding rgb.txt and every file of
// `also_required`; "" when neither place has them.
inline std::string FullTumSequence(const std::string& name,
                                   std::initializer_list<const char*> also_required = {}) {
  const std::string env = DataDirFromEnv();
  for (const std::string& dir : {env.empty() ? std::string() : env + "/" + name,
                                 std::string(LOCI_SOURCE_DIR) + "/../shared/data/" + name}) {
    if (dir.empty() || !std::filesystem::exists(dir + "/rgb.txt")) continue;
    bool all = true;
    for (const char* f : also_required) all = all && std::filesystem::exists(dir + "/" + f);
    if (all) return dir;
  }
  return "";
}

}  // namespace loci::testing
