// Cross-check of hex_quality against the independent checker ../shared/tools/hexcheck.py.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/hex_from_tets/split.h"
#include "nodes/quality/quality_json.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <string>
#include <unistd.h>

using namespace polyhex;
using namespace polyhex::test;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Output and exit status of a shell command.
std::pair<std::string, int> run(const std::string& cmd) {
  std::string out;
  FILE* f = popen((cmd + " 2>&1").c_str(), "r");
  if (!f) return {"", -1};
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  return {out, pclose(f)};
}

const std::string kPython = "/usr/bin/python3";
// Samples per side on both sides: enough for the tolerances below, few enough to keep the test fast.
constexpr int kSamples = 20000;
const fs::path kHexcheck = fs::path(POLYHEX_SHARED_DIR) / "tools" / "hexcheck.py";

// Why the cross-check cannot run here, or "" when it can.
std::string missing_prerequisite() {
  if (!fs::exists(kHexcheck)) return kHexcheck.string() + " not found";
  if (!fs::exists(kPython)) return kPython + " not found";
  if (run(kPython + " -c 'import numpy, scipy'").second != 0) return "numpy or scipy missing for " + kPython;
  return "";
}

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("polyhex-hexcheck-" + std::to_string(getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// hexcheck.py's JSON for a mesh file, optionally with a surface file.
json hexcheck(const std::string& mesh_file, const std::string& surface_file) {
  std::string cmd =
      kPython + " " + kHexcheck.string() + " " + mesh_file + " --json --samples " + std::to_string(kSamples);
  if (!surface_file.empty()) cmd += " --surface " + surface_file;
  const auto [out, status] = run(cmd);
  INFO("hexcheck output: " << out);
  REQUIRE(status == 0);
  return json::parse(out);
}

// Counts and percentages exactly, SJ figures to 1e-9, volumes relative 1e-9, distances to sampling
// tolerance: both sample kSamples points per side with different generators; ours are exact per
// sample, hexcheck's come from the 24 nearest centroids (never below the exact distance).
void compare_figures(const json& ours, const json& ref) {
  CHECK(ours.size() == ref.size());
  for (const char* k : {"hexes", "vertices", "inverted", "sj_below_0_2", "unused_vertices",
                        "faces_shared_by_more_than_two", "nonmanifold_boundary_edges", "boundary_quads"}) {
    INFO(k);
    CHECK(ours.at(k).get<long>() == ref.at(k).get<long>());
  }
  for (const char* k : {"irregular_pct", "irregular_interior_pct", "irregular_boundary_pct"}) {
    INFO(k);
    CHECK(ours.at(k).get<double>() == ref.at(k).get<double>());
  }
  for (const char* k : {"sj_min", "sj_avg", "sj_corner_min", "sj_corner_avg"}) {
    INFO(k);
    CHECK(std::abs(ours.at(k).get<double>() - ref.at(k).get<double>()) <= 1e-9);
  }
  CHECK(ours.at("volume").get<double>() == Approx(ref.at("volume").get<double>()).epsilon(1e-9));
  if (!ref.contains("hausdorff_mean")) return;
  for (const char* k : {"bbox_diag", "volume_ratio"}) {
    INFO(k);
    CHECK(ours.at(k).get<double>() == Approx(ref.at(k).get<double>()).epsilon(1e-9));
  }
  const double mean = ours.at("hausdorff_mean"), ref_mean = ref.at("hausdorff_mean");
  const double mx = ours.at("hausdorff_max"), ref_max = ref.at("hausdorff_max");
  INFO("hausdorff_mean " << mean << " vs " << ref_mean << ", hausdorff_max " << mx << " vs " << ref_max);
  CHECK(std::abs(mean - ref_mean) <= 0.05 * ref_mean + 1e-12);
  CHECK((std::abs(mx - ref_max) <= 0.1 * ref_max || std::abs(mx - ref_max) <= 2e-3));
}

// Writes the mesh with the project's writers (file name `name`, format `format` of write_hexmesh),
// runs hexcheck.py on the files and compares its figures with hex_quality on the mesh in memory:
// the writers print shortest round-trip decimals or raw doubles, so both see the same numbers.
void compare(const std::string& name, const std::string& format, const HexMesh& mesh, const SurfaceMesh& surface,
             const TempDir& dir) {
  INFO("mesh " << name << " (" << format << ")");
  const std::string file = (dir.path / name).string(), obj = (dir.path / (name + ".obj")).string();
  write_hexmesh(mesh, file, format);
  write_surface(surface, obj);
  QualityParams p;
  p.samples = kSamples;
  compare_figures(to_json(hex_quality(mesh, &surface, p)), hexcheck(file, obj));
}

}  // namespace

TEST_CASE("quality agrees with hexcheck.py on varied meshes", "[quality][hexcheck][shared]") {
  const std::string why = missing_prerequisite();
  if (!why.empty()) {
    WARN("skipping the hexcheck.py cross-check: " << why);
    SUCCEED();
    return;
  }
  TempDir dir;

  // A randomly perturbed grid: a spread of scaled Jacobians including a few inverted hexes,
  // measured against the unperturbed box.
  HexMesh grid = grid_hex_mesh(8, 7, 6, 0.5);
  const SurfaceMesh box = boundary_surface(grid);
  perturb(grid.V, 0.16, 5);
  compare("perturbed_grid.vtk", "vtk", grid, box, dir);

  // The baseline split of a perturbed box: all-irregular, valid hexes.
  TetMesh tets = box_tet_mesh(5, 4, 4, 0.5);
  perturb(tets.V, 0.06, 9);
  const HexMesh split = split_tets_to_hexes(tets);
  compare("split_box.vtk", "vtk_binary", split, boundary_surface(grid_hex_mesh(5, 4, 4, 0.5)), dir);

  // A broken mesh: a degenerate hex (an interior edge collapsed: hexcheck's distances would be NaN
  // for a degenerate boundary triangle), a hex used three times, an unused vertex.
  HexMesh broken = grid_hex_mesh(3, 3, 3);
  const SurfaceMesh broken_box = boundary_surface(broken);
  broken.V.row(21) = broken.V.row(22);  // interior vertex (1,1,1) onto (2,1,1)
  broken.V.conservativeResize(broken.V.rows() + 1, 3);
  broken.V.row(broken.V.rows() - 1) << 9, 9, 9;
  broken.H.conservativeResize(broken.H.rows() + 2, 8);
  broken.H.row(broken.H.rows() - 1) = broken.H.row(5);
  broken.H.row(broken.H.rows() - 2) = broken.H.row(5);
  compare("broken.mesh", "mesh", broken, broken_box, dir);
}

TEST_CASE("quality agrees with hexcheck.py on a published hex mesh", "[quality][hexcheck][shared]") {
  const std::string why = missing_prerequisite();
  const fs::path file =
      fs::path(POLYHEX_SHARED_DIR) / "data" / "reference_hex" / "tong2024_hybrid_octree" / "bunny.vtk";
  if (!why.empty() || !fs::exists(file)) {
    WARN("skipping the hexcheck.py cross-check on " << file << ": " << (why.empty() ? "file missing" : why));
    SUCCEED();
    return;
  }
  // 21695 hexes from an octree mesher, read by the project's reader (the file has CRLF line ends).
  const HexMesh mesh = read_hexmesh(file);
  const json ours = to_json(hex_quality(mesh, nullptr, {}));
  compare_figures(ours, hexcheck(file.string(), ""));
  CHECK(ours.at("hexes") == 21695);
  CHECK(ours.at("inverted") == 0);
}
