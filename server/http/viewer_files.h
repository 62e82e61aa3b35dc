// Where the web viewer's static files are (viewer/web in the source tree, assembled with the
// three.js files it imports into <build>/share/loci/viewer by the loci_viewer target) and how
// they are served: read-only from that one folder, no path outside it, a fixed content type per
// extension.
#pragma once

#include <string>

namespace httplib {
class Server;
}

namespace loci::server {

// The viewer folder when no --viewer-dir is given: $LOCI_HOME/viewer when LOCI_HOME is set, else
// ../share/loci/viewer beside the running binary (build/bin/loci-server ->
// build/share/loci/viewer, or an installed /usr/local/bin -> /usr/local/share/loci/viewer).
std::string DefaultViewerDir();
// Whether `dir` holds a viewer (an index.html).
bool HasViewer(const std::string& dir);
// Serves `dir` at "/" ("/" is its index.html) for GET and HEAD. Paths with ".." segments that
// would leave it are refused by cpp-httplib's path check; files only, never listings.
bool MountViewer(httplib::Server& http, const std::string& dir);

}  // namespace loci::server
