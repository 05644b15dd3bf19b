// SIGINT / SIGTERM during a long `polyhex run`: exit 130 within a few seconds, "interrupted" on
// stderr, no final mesh, no temporary file, report.json with status "interrupted".
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <signal.h>
#include <spawn.h>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

extern char** environ;

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using Clock = std::chrono::steady_clock;
using polyhex::test::read_text;

namespace {

/// Starts the polyhex binary with `args`, stdout and stderr into `log`. \return the pid
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {POLYHEX_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  // the child starts with no blocked signal (this process may block SIGINT/SIGTERM: runtime/cancel.h)
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &fa, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  REQUIRE(rc == 0);
  return pid;
}

/// Waits up to `limit` seconds for the child; \return its wait status, or -1 (the child is then killed).
int wait_for(pid_t pid, double limit) {
  const auto t0 = Clock::now();
  int status = 0;
  while (std::chrono::duration<double>(Clock::now() - t0).count() < limit) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

/// Files anywhere under `dir` whose name holds ".tmp" (runtime/atomic_file.cpp: NAME.tmp.PID.N).
std::vector<std::string> temp_files(const fs::path& dir) {
  std::vector<std::string> out;
  for (auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) out.push_back(e.path().string());
  return out;
}

/// Runs the default config with --save-all on a coarse built-in shape made finer inside; waits until
/// `marker` (a --save-all file of an earlier node) exists, so the signal lands in the node after it,
/// sends `sig`, and checks the outcome.
void interrupt_run(int sig, const std::string& marker, const std::string& signame) {
  fs::path dir = polyhex::test::fresh_dir("robust_" + signame);
  fs::path out = dir / "out", log = dir / "log.txt", surface = dir / "fandisk.obj";
  {
    pid_t p = spawn({"shapes", "fandisk_like", "--resolution", "16", "--out", surface.string()}, dir / "shapes.txt");
    REQUIRE(wait_for(p, 60) == 0);
  }
  pid_t pid =
      spawn({"run", std::string(POLYHEX_SOURCE_DIR) + "/configs/default.json", "--input", surface.string(), "--out",
             out.string(), "--threads", "2", "--save-all", "--set", "tets.edge_length=0.04", "--set",
             "rotate.iterations=50", "--set", "segment.hex_edge_length=0.015", "--set", "polycube.edge_length=0.015"},
            log);
  const auto t0 = Clock::now();
  bool exited_early = false;
  while (!fs::exists(out / marker)) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited_early = true;
      break;
    }
    if (std::chrono::duration<double>(Clock::now() - t0).count() > 120) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  INFO(read_text(log));
  REQUIRE_FALSE(exited_early);
  REQUIRE(fs::exists(out / marker));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // well inside the next node
  const auto t_sig = Clock::now();
  REQUIRE(::kill(pid, sig) == 0);
  const int status = wait_for(pid, 30);
  const double stop_seconds = std::chrono::duration<double>(Clock::now() - t_sig).count();
  const std::string output = read_text(log);
  INFO(output);
  INFO("stopped " << stop_seconds << " s after the signal");
  REQUIRE(status != -1);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  CHECK(stop_seconds < 5.0);
  CHECK_THAT(output, Contains("interrupted") && Contains("interrupted by " + signame));
  CHECK_FALSE(fs::exists(out / "hex.vtk"));
  CHECK(temp_files(dir).empty());
  const nlohmann::json rep = nlohmann::json::parse(read_text(out / "report.json"));
  CHECK(rep["status"] == "interrupted");
  CHECK_THAT(rep["error"].get<std::string>(), Contains("interrupted by " + signame));
  CHECK(rep["nodes"]["write"]["ran"] == false);
}

}  // namespace

TEST_CASE("interrupt: SIGINT during rotation_deform stops the run with 130, no mesh, no temp file", "[robust][cli]") {
  interrupt_run(SIGINT, "tets.vtk", "SIGINT");
}

TEST_CASE("interrupt: SIGTERM during position_deform stops the run with 130, no mesh, no temp file", "[robust][cli]") {
  interrupt_run(SIGTERM, "segment#1.charts.vtk", "SIGTERM");
}
