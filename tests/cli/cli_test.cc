// Every `loci` subcommand run as a process. The scene the
// map commands need is made by `loci bench ingest --keep` (12 keyframes of a synthetic room
// streamed into an in-process server, about 2 s), once per test process and only by the tests
// that use it; `ask`, `objects` and `stats` talk to a real loci-server on loopback serving a copy
// of its database. The benchmarks run at tiny sizes and only their header and first figures are
// checked; their default sizes (bench load 60 s, restart 1000 keyframes, graph 10,000
// keyframes, query 20,000 questions) take minutes and are not run here.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/tum_io.h"
#include "tests/support/server_process.h"

namespace loci {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kSample = std::string(LOCI_SOURCE_DIR) + "/tests/data/tum_fr1_rpy_sample";

struct Result {
  int rc = -1;
  std::string out, err;
};

std::ostream& operator<<(std::ostream& os, const Result& r) {
  return os << "exit " << r.rc << "\n--- stdout\n" << r.out << "--- stderr\n" << r.err;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `loci ARGS` (ARGS is a shell fragment); stdout and stderr apart.
Result Loci(const std::string& args) {
  static int n = 0;
  const fs::path err_path = fs::path(::testing::TempDir()) /
                            ("loci_cli_stderr_" + std::to_string(getpid()) + "_" +
                             std::to_string(n++));
  const std::string cmd = std::string(LOCI_BIN) + " " + args + " 2>" + err_path.string();
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf;
  while (size_t k = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), k);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = ReadFile(err_path);
  fs::remove(err_path);
  return r;
}

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("loci_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    fs::remove_all(dir_);
    if (!scene_.empty()) fs::remove_all(scene_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  // The ingested scene (scene/ with objects.json and groundtruth.txt, bench.db); made on first
  // use. The ingest's output is kept for BenchIngest.
  const Result& Ingest() {
    if (scene_.empty()) {
      scene_ = fs::path(::testing::TempDir()) / ("loci_cli_scene_" + std::to_string(getpid()));
      fs::remove_all(scene_);
      ingest_ = Loci("bench ingest --keyframes 12 --views 6 --objects 4 --keep " + scene_.string());
    }
    return ingest_;
  }
  std::string SceneDir() const { return (scene_ / "scene").string(); }
  // A copy of the ingested database (the server, export and reprocess open it for writing).
  std::string CopyDb(const std::string& name) {
    const std::string to = Path(name);
    for (const char* s : {"", "-wal", "-shm"}) {
      const fs::path from = scene_ / (std::string("bench.db") + s);
      if (fs::exists(from)) fs::copy_file(from, to + s, fs::copy_options::overwrite_existing);
    }
    return to;
  }
  // Classes of the exported objects JSON, counted.
  std::map<std::string, int> ExportedClasses(const std::string& db) {
    const std::string objects = Path("classes.json");
    const Result r = Loci("export --db " + db + " --objects " + objects);
    EXPECT_EQ(r.rc, 0) << r;
    std::map<std::string, int> classes;
    const json exported = json::parse(ReadFile(objects));
    for (const json& o : exported["objects"]) {
      ++classes[o["class_name"].get<std::string>()];
    }
    return classes;
  }

  fs::path dir_;
  fs::path scene_;
  Result ingest_;
};

TEST_F(Cli, HelpListsEverySubcommand) {
  const std::map<std::string, std::vector<std::string>> groups = {
      {"", {"eval", "synth", "export", "bench", "reprocess", "detect", "ask", "objects", "stats"}},
      {"eval", {"ate", "rpe", "objects"}},
      {"bench",
       {"ingest", "load", "merge", "restart", "graph", "detect", "track", "query", "place",
        "report"}}};
  for (const auto& [group, commands] : groups) {
    const Result r = Loci(group + " --help");
    ASSERT_EQ(r.rc, 0) << r;
    for (const std::string& c : commands) {
      EXPECT_TRUE(Has(r.out, "\n  " + c + " ")) << "`loci " << group << " --help` lacks " << c
                                               << ":\n" << r.out;
    }
  }
}

TEST_F(Cli, BadArgumentsExitNonZeroWithAMessage) {
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"", "subcommand"},
      {"frobnicate", "frobnicate"},
      {"bench", "subcommand"},
      {"bench frobnicate", "frobnicate"},
      {"synth", "--out is required"},
      {"synth --out " + Path("s") + " --frames 0", "frames must be >= 1"},
      {"eval ate /nonexistent/gt.txt /nonexistent/est.txt", "File does not exist"},
      {"export --db /nonexistent/loci.db", "File does not exist"},
      {"ask", "question is required"},
      {"objects --server 127.0.0.1:1 --timeout 5", "cannot reach loci-server"},
      {"stats --server 127.0.0.1:1 --timeout 5", "cannot reach loci-server"},
  };
  for (const Case& c : cases) {
    const Result r = Loci(c.args);
    EXPECT_NE(r.rc, 0) << "loci " << c.args << "\n" << r;
    EXPECT_TRUE(Has(r.out + r.err, c.message)) << "loci " << c.args << ": no \"" << c.message
                                               << "\"\n" << r;
  }
}

TEST_F(Cli, SynthWritesASmallSceneAndTheSameBytesForTheSameSeed) {
  const std::string args = " --frames 3 --objects 2 --width 160 --height 120 --threads 1 --seed 7";
  for (const char* name : {"a", "b"}) {
    const Result r = Loci("synth --out " + Path(name) + args);
    ASSERT_EQ(r.rc, 0) << r;
  }
  for (const char* file : {"rgb.txt", "depth.txt", "groundtruth.txt", "objects.json",
                           "detections.jsonl", "camera.yaml", "accelerometer.txt"}) {
    ASSERT_TRUE(fs::exists(dir_ / "a" / file)) << file;
    EXPECT_EQ(ReadFile(dir_ / "a" / file), ReadFile(dir_ / "b" / file)) << file;
  }
  const auto gt = ReadTumTrajectory(Path("a/groundtruth.txt"));
  ASSERT_TRUE(gt.ok()) << gt.status();
  EXPECT_EQ(gt->size(), 3u);
  // The table and the shelf besides the 2 objects.
  EXPECT_EQ(json::parse(ReadFile(dir_ / "a/objects.json"))["objects"].size(), 4u);
  size_t images = 0;
  for (const auto& e : fs::directory_iterator(dir_ / "a/rgb")) {
    EXPECT_EQ(ReadFile(e.path()), ReadFile(dir_ / "b/rgb" / e.path().filename()));
    ++images;
  }
  EXPECT_EQ(images, 3u);
}

TEST_F(Cli, AskObjectsAndStatsAgainstARunningServer) {
  ASSERT_EQ(Ingest().rc, 0) << Ingest();
  testing::ServerProcess server({.db = CopyDb("served.db"), .stderr_path = Path("server.log")});
  ASSERT_GT(server.port(), 0) << ReadFile(Path("server.log"));
  ASSERT_TRUE(server.serving().ok()) << server.serving();
  const std::string at = " --server " + server.address();

  const Result stats = Loci("stats --json" + at);
  ASSERT_EQ(stats.rc, 0) << stats;
  const json s = json::parse(stats.out);
  EXPECT_EQ(s["keyframes"], "12");  // int64 is a string in proto JSON
  const int n = std::stoi(s["objects"].get<std::string>());
  ASSERT_GT(n, 0);
  const Result stats_text = Loci("stats" + at);
  ASSERT_EQ(stats_text.rc, 0) << stats_text;
  EXPECT_TRUE(std::regex_search(stats_text.out, std::regex("\nkeyframes +12\n"))) << stats_text;

  const Result objects = Loci("objects --json" + at);
  ASSERT_EQ(objects.rc, 0) << objects;
  const json os = json::parse(objects.out)["objects"];
  ASSERT_EQ(static_cast<int>(os.size()), n);
  const std::string cls = os[0]["className"];
  const Result listed = Loci("objects" + at);
  ASSERT_EQ(listed.rc, 0) << listed;
  EXPECT_TRUE(Has(listed.out, std::to_string(n) + " objects")) << listed;
  EXPECT_TRUE(Has(listed.out, cls)) << listed;
  const Result only = Loci("objects --json --class '" + cls + "'" + at);
  ASSERT_EQ(only.rc, 0) << only;
  const json oj = json::parse(only.out)["objects"];
  ASSERT_FALSE(oj.empty());
  for (const json& o : oj) EXPECT_EQ(o["className"], cls);

  const Result ask = Loci("ask --json '" + std::string("where is the ") + cls + "'" + at);
  ASSERT_EQ(ask.rc, 0) << ask;
  const json a = json::parse(ask.out);
  EXPECT_EQ(a["intent"], "where");
  ASSERT_FALSE(a["objects"].empty()) << ask;
  for (const json& o : a["objects"]) EXPECT_EQ(o["className"], cls);
  const Result ask_text = Loci("ask '" + std::string("where is the ") + cls + "'" + at);
  ASSERT_EQ(ask_text.rc, 0) << ask_text;
  EXPECT_TRUE(Has(ask_text.out, cls + " (#")) << ask_text;
  const Result unseen = Loci("ask 'where is the giraffe'" + at);
  ASSERT_EQ(unseen.rc, 0) << unseen;
  EXPECT_TRUE(Has(unseen.out, "not seen any giraffes")) << unseen;

  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

TEST_F(Cli, ExportWritesTheMapProducts) {
  ASSERT_EQ(Ingest().rc, 0) << Ingest();
  const Result r = Loci("export --db " + CopyDb("export.db") + " --cloud " + Path("cloud.ply") +
                        " --objects " + Path("objects.json") + " --object-clouds " +
                        Path("objects") + " --octomap " + Path("map.bt") + " --trajectories " +
                        Path("trajectories"));
  ASSERT_EQ(r.rc, 0) << r;
  const std::string ply = ReadFile(Path("cloud.ply"));
  ASSERT_EQ(ply.substr(0, 4), "ply\n");
  EXPECT_TRUE(Has(ply, "format binary_little_endian 1.0\n"));
  std::smatch m;
  ASSERT_TRUE(std::regex_search(ply, m, std::regex("element vertex (\\d+)\n")));
  EXPECT_GT(std::stoi(m[1]), 0);

  const json objects = json::parse(ReadFile(Path("objects.json")));
  EXPECT_EQ(objects["frame"], "map");
  ASSERT_FALSE(objects["objects"].empty());
  for (const json& o : objects["objects"]) {
    EXPECT_FALSE(o["class_name"].get<std::string>().empty());
    EXPECT_EQ(o["centroid_m"].size(), 3u);
  }
  size_t clouds = 0;
  for (const auto& e : fs::directory_iterator(Path("objects"))) {
    EXPECT_EQ(e.path().extension(), ".ply");
    ++clouds;
  }
  EXPECT_EQ(clouds, objects["objects"].size());
  EXPECT_GT(fs::file_size(Path("map.bt")), 0u);
  const auto trajectory = ReadTumTrajectory(Path("trajectories/bench.tum"));
  ASSERT_TRUE(trajectory.ok()) << trajectory.status();
  EXPECT_EQ(trajectory->size(), 12u);
}

TEST_F(Cli, ReprocessRebuildsTheSameObjects) {
  ASSERT_EQ(Ingest().rc, 0) << Ingest();
  const std::string db = CopyDb("reprocess.db");
  const std::map<std::string, int> before = ExportedClasses(db);
  ASSERT_FALSE(before.empty());
  const Result r = Loci("reprocess --db " + db);
  ASSERT_EQ(r.rc, 0) << r;
  EXPECT_TRUE(Has(r.out, "reprocessed 12 keyframes")) << r;
  EXPECT_EQ(ExportedClasses(db), before);
}

TEST_F(Cli, EvalObjectsOnTheIngestedScene) {
  ASSERT_EQ(Ingest().rc, 0) << Ingest();
  const Result r = Loci("eval objects --json --no-ask --gt " + SceneDir() + "/objects.json" +
                        " --groundtruth " + SceneDir() + "/groundtruth.txt --db " +
                        CopyDb("eval.db"));
  ASSERT_EQ(r.rc, 0) << r;
  const json e = json::parse(r.out);  // stdout is the JSON alone (logs go to stderr)
  const auto gt = ReadTumTrajectory(SceneDir() + "/groundtruth.txt");  // one pose per view
  ASSERT_TRUE(gt.ok()) << gt.status();
  EXPECT_EQ(e["alignment_pairs"], gt->size());
  EXPECT_LT(e["alignment_ate_rmse_m"].get<double>(), 1e-6);  // the stream used the true poses
  EXPECT_GE(e["precision"].get<double>(), 0.75) << r.out;
  EXPECT_GT(e["recall"].get<double>(), 0.5) << r.out;
}

// Writes `traj` moved by T (and, with wiggle_m, every other position moved by +-wiggle_m in x).
std::string WriteMoved(const std::string& path, Trajectory traj, const SE3d& T, double wiggle_m) {
  for (size_t i = 0; i < traj.size(); ++i) {
    traj[i].T_world_cam = T * traj[i].T_world_cam;
    traj[i].T_world_cam.translation().x() += (i % 2 == 0 ? wiggle_m : -wiggle_m);
  }
  EXPECT_TRUE(WriteTumTrajectory(path, traj).ok());
  return path;
}

TEST_F(Cli, EvalAteAndRpeOnTheShippedSample) {
  const std::string gt = kSample + "/groundtruth.txt";
  const auto traj = ReadTumTrajectory(gt);
  ASSERT_TRUE(traj.ok()) << traj.status();
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.5, Vec3d(0.2, 0.3, 0.9).normalized()).toRotationMatrix();
  T.translation() = Vec3d(1.0, -2.0, 0.5);
  // A rigid move of the ground truth: nothing left after the alignment.
  const std::string rigid = WriteMoved(Path("rigid.txt"), *traj, T, 0.0);
  Result r = Loci("eval ate --json " + gt + " " + rigid);
  ASSERT_EQ(r.rc, 0) << r;
  json j = json::parse(r.out);
  EXPECT_EQ(j["pairs"], traj->size());
  EXPECT_LT(j["trans_m"]["rmse"].get<double>(), 1e-6);
  r = Loci("eval rpe --json --delta 0.1 " + gt + " " + rigid);
  ASSERT_EQ(r.rc, 0) << r;
  j = json::parse(r.out);
  EXPECT_GT(j["pairs"].get<int>(), 0);
  EXPECT_LT(j["trans_m_per_delta"]["rmse"].get<double>(), 1e-6);
  // 1 cm of alternating error survives the alignment (it has no rigid part).
  const std::string wiggled = WriteMoved(Path("wiggled.txt"), *traj, T, 0.01);
  r = Loci("eval ate --json " + gt + " " + wiggled);
  ASSERT_EQ(r.rc, 0) << r;
  EXPECT_NEAR(json::parse(r.out)["trans_m"]["rmse"].get<double>(), 0.01, 5e-4) << r.out;
  r = Loci("eval ate " + gt + " " + wiggled);
  ASSERT_EQ(r.rc, 0) << r;
  EXPECT_TRUE(Has(r.out, "ATE rmse 0.0100 m (" + std::to_string(traj->size()) + " pairs)")) << r;
}

TEST_F(Cli, DetectFindsObjectsInASampleImage) {
  const Result r = Loci("detect --json " + std::string(LOCI_SOURCE_DIR) +
                        "/tests/data/frames/1305031249.497685.jpg");
  ASSERT_EQ(r.rc, 0) << r;
  const json j = json::parse(r.out.substr(0, r.out.find('\n')));
  ASSERT_FALSE(j["detections"].empty()) << r.out;
  for (const json& d : j["detections"]) {
    EXPECT_EQ(d["box"].size(), 4u);
    EXPECT_GT(d["score"].get<double>(), 0.0);
  }
}

// The benchmarks at tiny sizes: each starts, prints its header and its first figures.
TEST_F(Cli, BenchIngest) {
  const Result& r = Ingest();
  ASSERT_EQ(r.rc, 0) << r;
  EXPECT_TRUE(Has(r.out, "loci bench ingest: 12 keyframes")) << r;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("map +[1-9][0-9]* objects"))) << r;
}

struct BenchCase {
  std::string args, header;
};

void RunBench(const BenchCase& c) {
  const Result r = Loci("bench " + c.args);
  ASSERT_EQ(r.rc, 0) << "loci bench " << c.args << "\n" << r;
  EXPECT_TRUE(Has(r.out, c.header)) << "loci bench " << c.args << ": no \"" << c.header << "\"\n"
                                    << r;
}

TEST_F(Cli, BenchLoad) {
  RunBench({"load --robots 1 --clients 1 --seconds 1 --views 3 --objects 2",
            "loci bench load: 1 robots"});
}
TEST_F(Cli, BenchMerge) {
  RunBench({"merge --views 12 --start 6 --objects 3 --robot-hz 0", "loci bench merge: 12"});
}
TEST_F(Cli, BenchRestart) {
  RunBench({"restart --keyframes 5 --small", "loci bench restart: 5 keyframes"});
}
TEST_F(Cli, BenchGraph) {
  RunBench({"graph --keyframes 100 --per-lap 50 --wrong-loops 1", "SYNTHETIC pose graphs"});
}
TEST_F(Cli, BenchQuery) {
  RunBench({"query --objects 100 --queries 200 --threads 1 --grpc-queries 20",
            "loci bench query: 100 objects"});
}
TEST_F(Cli, BenchTrack) {
  RunBench({"track --tum " + kSample + " --max-frames 10", "frames            10"});
}
TEST_F(Cli, BenchDetect) {
  RunBench({"detect --tum " + kSample + " --frames 2", "loci bench detect: 2 frames"});
}
TEST_F(Cli, BenchPlace) {
  RunBench({"place --tum " + kSample + " --sizes 50 --queries 5 --max-frames 20",
            "loci bench place:"});
}
TEST_F(Cli, BenchReport) {
  RunBench({"report --tum " + kSample + " --max-frames 10", "## loci report"});
}

}  // namespace
}  // namespace loci
