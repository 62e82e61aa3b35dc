// The loci-server program's start-up: unknown config keys warn, or with --strict-config stop it
// before it listens (exit code 2) naming the file and the key. Its threads carry names.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "tests/support/server_process.h"
#include "tests/support/temp_dir.h"

namespace loci::testing {
namespace {

class ServerBinary : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    std::ofstream(Path("server.yaml")) << "map:\n  cloud:\n    voxle_m: 0.02\n";
  }
  std::string Read(const std::string& name) const {
    std::ifstream in(Path(name));
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  ServerProcessOptions Options(std::vector<std::string> extra) const {
    return {.db = Path("loci.db"),
            .config = Path("server.yaml"),
            .extra_args = std::move(extra),
            .stderr_path = Path("server.err")};
  }
};

TEST_F(ServerBinary, UnknownConfigKeyWarnsAndServes) {
  ServerProcess server(Options({}));
  ASSERT_GT(server.port(), 0) << Read("server.err");
  const int status = server.Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  const std::string expected = Path("server.yaml") + ":3: unknown key 'voxle_m' in 'map.cloud'";
  EXPECT_NE(Read("server.err").find(expected), std::string::npos) << Read("server.err");
}

TEST_F(ServerBinary, StrictConfigRefusesToStart) {
  ServerProcess server(Options({"--strict-config"}));
  EXPECT_EQ(server.port(), 0);  // ended before listening
  const int status = server.Stop(0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
  EXPECT_NE(Read("server.err").find("unknown key 'voxle_m' in 'map.cloud'"), std::string::npos)
      << Read("server.err");
}

// The threads as the kernel names them (what top -H and perf --sort comm show).
std::set<std::string> ThreadNames(pid_t pid) {
  std::set<std::string> names;
  const std::filesystem::path tasks = "/proc/" + std::to_string(pid) + "/task";
  for (const auto& task : std::filesystem::directory_iterator(tasks)) {
    std::ifstream in(task.path() / "comm");
    std::string name;
    if (std::getline(in, name)) names.insert(name);
  }
  return names;
}

TEST_F(ServerBinary, ItsThreadsAreNamed) {
  ServerProcess server(Options({"--http", "127.0.0.1:0"}));
  ASSERT_GT(server.port(), 0) << Read("server.err");
  ASSERT_TRUE(server.serving().ok()) << server.serving().ToString();
  const std::set<std::string> names = ThreadNames(server.pid());
  std::string all;
  for (const std::string& n : names) all += n + " ";
  for (const char* expected :
       {"loci-worker", "loci-align", "loci-octomap", "loci-rebuild", "loci-http"}) {
    EXPECT_TRUE(names.count(expected)) << expected << " is not among: " << all;
  }
  const int status = server.Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

}  // namespace
}  // namespace loci::testing
