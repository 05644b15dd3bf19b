// Plumbing of the end-to-end tests: running the polyhex binary (POLYHEX_BINARY) or a shell command and
// capturing its exit code and output, temporary folders, reading a whole file. Header-only.
#pragma once

#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <unistd.h>

namespace polyhex::test {

/// Outcome of one command.
struct CliRun {
  int code = -1;       ///< exit status, or -1 when the command did not exit normally (signal)
  std::string out;     ///< what was captured from the command's stdout (see each runner for redirections)
  std::string err;     ///< stderr when captured separately, else empty
  double seconds = 0;  ///< wall-clock time of the command
};

/// Whole content of the file `p` (binary); empty when it cannot be opened.
inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// Exit code of a `system`/`pclose` status: WEXITSTATUS, or -1 when the child did not exit normally.
inline int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; }

/// Starts `sh -c cmd` with its stdout readable through the returned pipe (pass it to finish_command).
/// \pre cmd is a complete shell command line (add "2>&1" to capture stderr too)
/// \throw nothing; a failing popen fails the current test (REQUIRE)
inline FILE* start_command(const std::string& cmd) {
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  return p;
}

/// Reads the pipe of start_command to its end and closes it (`seconds` is left 0: use run_command to time).
inline CliRun finish_command(FILE* p) {
  CliRun r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  r.code = exit_code(pclose(p));
  return r;
}

/// Runs the shell command `cmd` and captures its stdout in `out` (nothing is redirected for you);
/// `seconds` covers the whole command.
inline CliRun run_command(const std::string& cmd) {
  const auto t0 = std::chrono::steady_clock::now();
  CliRun r = finish_command(start_command(cmd));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

/// Starts `polyhex ARGS 2>&1`; finish_command gives stdout and stderr together in `out`. Two started
/// runs proceed concurrently.
inline FILE* start_polyhex(const std::string& args) {
  return start_command(std::string(POLYHEX_BINARY) + " " + args + " 2>&1");
}

/// Runs `polyhex ARGS` (ARGS is shell text); stdout and stderr together in `out`.
inline CliRun run_polyhex(const std::string& args) {
  return run_command(std::string(POLYHEX_BINARY) + " " + args + " 2>&1");
}

/// Runs the shell command `cmd` with stdout into the file `out_file` and stderr into `err_file`, then reads
/// both back into `out` and `err` (the files stay, for inspection).
inline CliRun run_command_to_files(const std::string& cmd, const std::filesystem::path& out_file,
                                   const std::filesystem::path& err_file) {
  const std::string full = cmd + " > '" + out_file.string() + "' 2> '" + err_file.string() + "'";
  CliRun r;
  const auto t0 = std::chrono::steady_clock::now();
  r.code = exit_code(std::system(full.c_str()));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.out = read_text(out_file);
  r.err = read_text(err_file);
  return r;
}

/// Runs `polyhex ARGS` as run_command_to_files does.
inline CliRun run_polyhex_to_files(const std::string& args, const std::filesystem::path& out_file,
                                   const std::filesystem::path& err_file) {
  return run_command_to_files(std::string(POLYHEX_BINARY) + " " + args, out_file, err_file);
}

/// An empty folder `<temp>/polyhex_<name>_<pid>` (emptied if it exists). It is left in place after the
/// test, so the outputs of a failing run can be inspected.
inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / ("polyhex_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// A fresh empty folder `<temp>/polyhex_<name>_<pid>_<n>` (n counts the TempDirs of this process),
/// removed with its content at the end of the scope.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& name = "test") {
    static std::atomic<int> n{0};
    path = std::filesystem::temp_directory_path() /
           ("polyhex_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(n++));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::filesystem::path operator/(const std::string& name) const { return path / name; }
};

}  // namespace polyhex::test
