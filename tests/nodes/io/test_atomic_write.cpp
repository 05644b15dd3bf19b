// write_file_atomic and the mesh writers under output faults: a failing stream, a full disk (a file
// size limit), a name clash with a folder, a parent that is a file, an unwritable folder. Nothing is
// ever left under the final name and no temporary file is left behind.
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "runtime/atomic_file.h"
#include "runtime/errors.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>
#include <sys/resource.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

std::string content(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// Names of the entries of a folder.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> out;
  for (auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// Sets RLIMIT_FSIZE (with SIGXFSZ ignored, so writes fail with EFBIG) for the scope.
struct FileSizeLimit {
  rlimit old{};
  void (*old_handler)(int) = nullptr;
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old);
    old_handler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit r = old;
    r.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &r);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
};

}  // namespace

TEST_CASE("write_file_atomic: a failing fill leaves nothing, an existing file is kept", "[io][badinput]") {
  TempDir dir;
  const fs::path p = dir / "out.txt";
  write_text(p, "old content\n");
  SECTION("fill throws") {
    REQUIRE_THROWS_WITH(write_file_atomic(p,
                                          [](std::ostream& os) {
                                            os << "half";
                                            throw InvalidInput("stop");
                                          }),
                        "stop");
  }
  SECTION("the stream fails (as on a full disk)") {
    REQUIRE_THROWS_AS(write_file_atomic(p,
                                        [](std::ostream& os) {
                                          os << "half";
                                          os.setstate(std::ios::badbit);
                                        }),
                      IOError);
    REQUIRE_THROWS_WITH(write_file_atomic(p, [](std::ostream& os) { os.setstate(std::ios::failbit); }),
                        Contains(p.string() + ": write failed") && Contains("no file written"));
  }
  CHECK(content(p) == "old content\n");
  CHECK(entries(dir.path) == std::vector<std::string>{"out.txt"});
}

TEST_CASE("write_file_atomic: a full disk (file size limit) fails with the reason, nothing left", "[io][badinput]") {
  TempDir dir;
  const fs::path p = dir / "big.vtk";
  {
    FileSizeLimit limit(64 * 1024);
    REQUIRE_THROWS_WITH(write_hexmesh(hex_grid(12), p, "vtk"),
                        Contains(p.string() + ": write failed: File too large") && Contains("no file written"));
    // A small file still fits.
    write_file_atomic(dir / "small.txt", [](std::ostream& os) { os << "ok\n"; });
  }
  CHECK(entries(dir.path) == std::vector<std::string>{"small.txt"});
}

TEST_CASE("write_file_atomic: name clashes and unwritable folders", "[io][badinput]") {
  TempDir dir;
  fs::create_directories(dir / "taken.vtk");
  write_text(dir / "afile", "x");
  auto fill = [](std::ostream& os) { os << "data\n"; };
  SECTION("the output path is an existing folder") {
    REQUIRE_THROWS_AS(write_file_atomic(dir / "taken.vtk", fill), IOError);
    REQUIRE_THROWS_WITH(write_file_atomic(dir / "taken.vtk", fill),
                        (dir / "taken.vtk").string() + ": cannot write the file: a folder of that name exists");
    CHECK(fs::is_empty(dir / "taken.vtk"));
  }
  SECTION("the parent is a file") {
    REQUIRE_THROWS_WITH(write_file_atomic(dir / "afile" / "x.vtk", fill),
                        Contains("x.vtk: cannot write the file: ") && Contains("afile is a file, not a folder"));
  }
  SECTION("the folder does not exist") {
    REQUIRE_THROWS_WITH(write_file_atomic(dir / "nowhere" / "x.vtk", fill),
                        Contains("x.vtk: cannot open for writing: No such file or directory"));
  }
  SECTION("the folder is read-only") {
    if (::geteuid() == 0) {
      // root ignores permissions: use a read-only file system instead
      REQUIRE_THROWS_WITH(write_file_atomic("/proc/polyhex_test.vtk", fill),
                          Contains("/proc/polyhex_test.vtk: cannot open for writing"));
    } else {
      fs::create_directories(dir / "ro");
      fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
      REQUIRE_THROWS_WITH(write_file_atomic(dir / "ro" / "x.vtk", fill),
                          Contains("x.vtk: cannot open for writing: Permission denied"));
      fs::permissions(dir / "ro", fs::perms::owner_all);
      CHECK(fs::is_empty(dir / "ro"));
    }
  }
  SECTION("the mesh writers report the same") {
    REQUIRE_THROWS_WITH(write_surface(SurfaceMesh{}, dir / "taken.vtk"), Contains("a folder of that name exists"));
  }
  std::vector<std::string> names = entries(dir.path);
  for (const auto& n : names) CHECK(n.find(".tmp.") == std::string::npos);
}
