#include "server/http/viewer_files.h"

#include <cstdlib>
#include <filesystem>
#include <system_error>

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {

namespace fs = std::filesystem;

std::string DefaultViewerDir() {
  const char* home = std::getenv("LOCI_HOME");
  if (home != nullptr && *home != '\0') return (fs::path(home) / "viewer").string();
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return "viewer";
  return (exe.parent_path().parent_path() / "share/loci/viewer").lexically_normal().string();
}

bool HasViewer(const std::string& dir) {
  std::error_code ec;
  return !dir.empty() && fs::is_regular_file(fs::path(dir) / "index.html", ec);
}

bool MountViewer(httplib::Server& http, const std::string& dir) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {"html", "text/html; charset=utf-8"},  {"js", "text/javascript; charset=utf-8"},
      {"css", "text/css; charset=utf-8"},    {"json", "application/json"},
      {"png", "image/png"},                  {"svg", "image/svg+xml"},
      {"ico", "image/x-icon"},               {"txt", "text/plain; charset=utf-8"}};
  for (const auto& [ext, type] : kTypes) http.set_file_extension_and_mimetype_mapping(ext, type);
  const httplib::Headers headers = {{"Cache-Control", "no-cache"},
                                    {"X-Content-Type-Options", "nosniff"}};
  return http.set_mount_point("/", fs::absolute(dir).lexically_normal().string(), headers);
}

}  // namespace loci::server
