// `loci export --db FILE [--config server.yaml] [--cloud out.ply] [--objects out.json]
//  [--object-clouds DIR] [--octomap out.bt] [--trajectories DIR] [--voxel M] [--all]`: rebuilds
// the map offline from a loci-server database (read-only) and writes its products, all in the
// map frame.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iostream>

#include "cli/commands.h"
#include "common/image_codec.h"
#include "common/tum_io.h"
#include "server/map/map_export.h"
#include "server/map/mapper.h"
#include "server/runtime/replay.h"
#include "server/runtime/server_options.h"
#include "server/storage/sqlite_store.h"

namespace loci::cli {
namespace {

struct ExportArgs {
  std::string db, config, cloud, objects, object_clouds, octomap, trajectories;
  double voxel_m = 0;
  bool all = false;
};

// Options of the server that wrote the DB: --config, else the defaults + classes.yaml.
StatusOr<server::ServerOptions> LoadServerOptions(const std::string& config) {
  server::ServerOptions o;
  LOCI_RETURN_IF_ERROR(config.empty() ? o.LoadClasses() : o.FromYamlFile(config));
  return o;
}

// One TUM file per robot (DIR/ROBOT.tum) with its keyframe camera poses in the map frame.
Status ExportTrajectories(const server::Mapper& mapper, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return absl::PermissionDeniedError(absl::StrCat("cannot create ", dir, ": ", ec.message()));
  for (const auto& [robot, traj] : mapper.Trajectories()) {
    std::string name = robot;
    for (char& c : name) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    }
    const std::string path = absl::StrCat(dir, "/", name, ".tum");
    LOCI_RETURN_IF_ERROR(WriteTumTrajectory(path, traj));
    std::cout << "trajectory: " << robot << ", " << traj.size() << " keyframes -> " << path << "\n";
  }
  return absl::OkStatus();
}

int RunExport(const ExportArgs& a) {
  auto options = LoadServerOptions(a.config);
  if (!options.ok()) {
    std::cerr << "error: " << options.status().message() << "\n";
    return 2;
  }
  server::SqliteStoreOptions store_options;
  store_options.read_only = true;
  auto store = server::SqliteStore::Open(a.db, store_options);
  if (!store.ok()) {
    std::cerr << "error: " << store.status().message() << "\n";
    return 1;
  }
  auto mapper_ptr = std::make_unique<server::Mapper>(options->map);
  // Stored keyframes without detections or products are exported as stored (no detector
  // offline); the database is not written.
  server::LoadOptions load;
  load.store_products = false;
  auto loaded = server::LoadMap(**store, &mapper_ptr, nullptr, load);
  if (!loaded.ok()) {
    std::cerr << "error: " << loaded.status().message() << "\n";
    return 1;
  }
  server::Mapper& mapper = *mapper_ptr;
  const uint64_t n = loaded->keyframes();
  const auto objects = mapper.Snapshot(!a.all);
  if (loaded->checkpoint_keyframe_id > 0) {
    std::cout << "checkpoint up to keyframe " << loaded->checkpoint_keyframe_id << ", then ";
  }
  std::cout << "mapped " << n << " keyframes: " << objects.size()
            << (a.all ? " objects" : " confirmed objects") << "\n";
  Status st;
  if (!a.cloud.empty()) {
    const auto points = mapper.Cloud(a.voxel_m, {});
    st.Update(server::WritePly(a.cloud, points));
    std::cout << "cloud: " << points.size() << " points -> " << a.cloud << "\n";
  }
  if (!a.objects.empty()) {
    st.Update(server::WriteObjectsJsonExport(a.objects, objects,
                                             mapper.UpDirection().value_or(Vec3d::UnitZ())));
    std::cout << "objects: " << objects.size() << " -> " << a.objects << "\n";
  }
  if (!a.object_clouds.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.object_clouds, ec);
    for (const MapObject& o : objects) {
      std::vector<server::ColoredPoint> cloud;
      mapper.GetObject(o.id, &cloud, nullptr);
      std::vector<server::SemanticPoint> points;
      for (const auto& p : cloud) points.push_back({p.p_m, p.rgb, o.id});
      std::string name = o.class_name;
      std::replace(name.begin(), name.end(), ' ', '_');
      st.Update(server::WritePly(absl::StrCat(a.object_clouds, "/object_", o.id, "_", name, ".ply"),
                                 points));
    }
    std::cout << "object clouds: " << objects.size() << " files -> " << a.object_clouds << "\n";
  }
  if (!a.trajectories.empty()) st.Update(ExportTrajectories(mapper, a.trajectories));
  if (!a.octomap.empty()) {
    const std::string bt = mapper.OctomapBt();
    st.Update(WriteFileBytes(a.octomap, bt));
    std::cout << "octomap: " << bt.size() << " bytes -> " << a.octomap << "\n";
  }
  if (!st.ok()) {
    std::cerr << "error: " << st.message() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

void RegisterExportCommand(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* c = app.add_subcommand(
      "export", "Rebuild the map offline from a loci-server database and write its products");
  c->add_option("--db", args->db, "loci-server SQLite database")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--config", args->config, "server YAML the DB was written with (map options)")
      ->check(CLI::ExistingFile);
  c->add_option("--cloud", args->cloud, "semantic cloud, binary PLY (map frame)");
  c->add_option("--objects", args->objects, "objects JSON (superset of objects.json)");
  c->add_option("--object-clouds", args->object_clouds, "directory for one PLY per object");
  c->add_option("--octomap", args->octomap, "OctoMap .bt file");
  c->add_option("--trajectories", args->trajectories,
                "directory for one TUM trajectory per robot (keyframe poses, map frame)");
  c->add_option("--voxel", args->voxel_m, "cloud voxel size, m (0 = the map's)");
  c->add_flag("--all", args->all,
              "include unconfirmed candidate objects (their views, missed_views and existence "
              "show what holds them back)");
  c->callback([args] { ExitCode() = RunExport(*args); });
}

}  // namespace loci::cli
