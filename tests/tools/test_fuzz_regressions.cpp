// Fuzzing regressions: every input in tests/fixtures/fuzz/<target>/ (tools/fuzz.sh findings and
// hand-written inputs of the same class) is fed to its reader, which must throw polyhex::Error: not
// crash, not throw std::bad_alloc / std::length_error, not try to allocate what a header count says.
//
// The bugs they caught: readers reserved/resized by a header count before checking it against the file
// (now TextCursor::checked_count); load_config_json let nlohmann's out_of_range (1e400) escape; a vars
// product ("1e999 * ${two}") let std::stod's out_of_range escape, and one that overflowed became inf.
#include "graph/config.h"
#include "graph/pipeline.h"
#include "runtime/errors.h"
#include "tests/fuzz/fuzz_common.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

std::vector<fs::path> fixtures(const std::string& target) {
  std::vector<fs::path> out;
  const fs::path dir = fs::path(POLYHEX_SOURCE_DIR) / "tests" / "fixtures" / "fuzz" / target;
  if (fs::is_directory(dir))
    for (auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<uint8_t> bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Feeds every fixture of `target` to `read` and requires a polyhex::Error.
template <class Read>
void check_target(const std::string& target, size_t at_least, Read read) {
  const auto files = fixtures(target);
  REQUIRE(files.size() >= at_least);
  for (const fs::path& f : files) {
    DYNAMIC_SECTION(target << "/" << f.filename().string()) {
      const std::vector<uint8_t> data = bytes(f);
      REQUIRE(data.size() > 1);
      CHECK_THROWS_AS(read(data.data(), data.size()), polyhex::Error);
    }
  }
}

}  // namespace

TEST_CASE("fuzz regressions: surface readers (OBJ/OFF/STL/PLY)", "[robust]") {
  check_target("surface", 5, [](const uint8_t* d, size_t n) { polyhex_fuzz::read_surface_input(d, n, nullptr); });
}

TEST_CASE("fuzz regressions: tet mesh readers (Medit/VTK/Gmsh/TetGen)", "[robust]") {
  check_target("tetmesh", 8, [](const uint8_t* d, size_t n) { polyhex_fuzz::read_tetmesh_input(d, n, nullptr); });
}

TEST_CASE("fuzz regressions: hex mesh readers (VTK/Medit/Gmsh)", "[robust]") {
  check_target("hexmesh", 2, [](const uint8_t* d, size_t n) { polyhex_fuzz::read_hexmesh_input(d, n, nullptr); });
}

TEST_CASE("fuzz regressions: config path (load, parse, build)", "[robust]") {
  const auto files = fixtures("config");
  REQUIRE(files.size() >= 2);
  for (const fs::path& f : files) {
    DYNAMIC_SECTION("config/" << f.filename().string()) {
      CHECK_THROWS_AS(polyhex::Pipeline::build(
                          polyhex::parse_config(polyhex::load_config_json(f, {{"input", "in.off"}}), f.string())),
                      polyhex::ConfigError);
    }
  }
}
