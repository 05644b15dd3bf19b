// Read-back of the hex meshes polyhex writes by real clients (our own readers do not count): meshio reads
// each of .e, .inp, .msh, .vtk, .mesh (tests/nodes/io/clients/read_back.py says how each format's groups
// reach it), the gmsh CLI opens the .msh and writes it back. The clients are installed by tools/setup.sh:
// under CI (CI=true) a missing client fails the test; elsewhere it is skipped with a warning.
#include "nodes/formats/hexmesh_io.h"
#include "tests/helpers/cli.h"
#include "tests/helpers/io_checks.h"
#include "tests/helpers/report.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace fs = std::filesystem;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::run_command;
using polyhex::test::run_polyhex;

namespace {

const char* kPython = "/usr/bin/python3";

std::string shell_quoted(const fs::path& p) { return "'" + p.string() + "'"; }

/// Whether the client answers `probe`; under CI a missing client is a failure.
bool client_available(const std::string& probe, const std::string& what) {
  const CliRun r = run_command(probe + " >/dev/null 2>&1");
  if (r.code == 0) return true;
  const char* ci = std::getenv("CI");
  if (ci && std::string(ci) == "true")
    FAIL(what << " is missing (tools/setup.sh installs it); `" << probe << "` failed");
  WARN("skipped: " << what << " is missing (`" << probe << "` failed); tools/setup.sh installs it");
  return false;
}

bool meshio_available() {
  return client_available(std::string(kPython) + " -c 'import meshio, netCDF4'",
                          "meshio with netCDF4 (python3-meshio)");
}

/// What read_back.py finds in `file` (the JSON of its last output line).
json read_back(const fs::path& file) {
  const std::string script = std::string(POLYHEX_SOURCE_DIR) + "/tests/nodes/io/clients/read_back.py";
  const CliRun r = run_command(std::string(kPython) + " " + shell_quoted(script) + " " + shell_quoted(file) + " 2>&1");
  INFO(file.string() << ":\n" << r.out);
  REQUIRE(r.code == 0);
  const size_t end = r.out.find_last_not_of("\n");
  REQUIRE(end != std::string::npos);
  const size_t start = r.out.rfind('\n', end);
  return json::parse(
      r.out.substr(start == std::string::npos ? 0 : start + 1, end + 1 - (start == std::string::npos ? 0 : start + 1)));
}

/// The default pipeline on shape:box at a coarse size, its mesh written in every format (once per process).
struct BoxRun {
  fs::path dir;
  json report;
};
const BoxRun& box_run() {
  static const BoxRun run = [] {
    BoxRun b;
    b.dir = polyhex::test::fresh_dir("hex_clients");
    std::ifstream in(std::string(POLYHEX_SOURCE_DIR) + "/configs/default.json");
    json cfg = json::parse(in);
    json nodes = json::array();
    for (const json& n : cfg["nodes"])
      if (n["id"] != "write") nodes.push_back(n);
    for (const char* ext : {"e", "inp", "msh", "vtk", "mesh"})
      nodes.push_back({{"id", std::string("write_") + ext},
                       {"type", "write_hex"},
                       {"params", {{"path", std::string("hex.") + ext}}},
                       {"inputs", {{"mesh", "best"}}}});
    cfg["nodes"] = nodes;
    std::ofstream(b.dir / "config.json") << cfg.dump(1);
    const CliRun r = run_polyhex("run " + shell_quoted(b.dir / "config.json") + " --input shape:box --out " +
                                 shell_quoted(b.dir / "out") +
                                 " --set tets.edge_length=0.2 --set segment.hex_edge_length=0.2"
                                 " --set polycube.edge_length=0.2 --threads 2 --no-cache");
    INFO(r.out);
    REQUIRE(r.code == 0);
    std::ifstream rep(b.dir / "out" / "report.json");
    b.report = json::parse(rep);
    return b;
  }();
  return run;
}

/// Sum of the sizes of the groups named `<family>_<n>`.
long family_total(const json& groups, const std::string& family) {
  long n = 0;
  for (auto& [name, size] : groups.items())
    if (name.rfind(family + "_", 0) == 0) n += size.get<long>();
  return n;
}

}  // namespace

TEST_CASE("clients: meshio reads the hexes and the boundary groups of every format polyhex writes", "[io][clients]") {
  if (!meshio_available()) return;
  const BoxRun& run = box_run();
  const json& q = run.report["nodes"]["quality"]["metrics"];
  const json g = polyhex::test::kept_node(run.report, "groups")["metrics"];
  const long hexes = q["hexes"].get<long>();
  REQUIRE(hexes >= 16);  // the box's lattice, 4 x 2 x 2 cubes at this size: no padding layer on a box
  // a box: six charts and six sharp-edge patches
  CHECK(g["chart_groups"] == 6);
  CHECK(g["patch_groups"] == 6);
  CHECK(g["groups"] == 13);
  const long faces = g["boundary_faces"].get<long>();

  std::map<std::string, json> got;
  for (const char* ext : {"e", "inp", "msh", "vtk", "mesh"}) {
    INFO("hex." << ext);
    const json r = read_back(run.dir / "out" / (std::string("hex.") + ext));
    got[ext] = r;
    CHECK(r["hexes"] == hexes);
    CHECK(r["min_jacobian"].get<double>() > 0);  // positive in meshio's vertex order
    CHECK(r["not_boundary"] == 0);
    CHECK(r["inward"] == 0);
    CHECK(r["outside_nodes"] == 0);
  }
  // Exodus side sets, Abaqus surfaces, Gmsh physical groups and VTK family arrays give the same 13 groups
  const json& ref = got["e"]["groups"];
  REQUIRE(ref.size() == 13);
  CHECK(ref["boundary"] == faces);
  CHECK(family_total(ref, "chart") == faces);  // charts and patches each cover the boundary once
  CHECK(family_total(ref, "patch") == faces);
  for (const char* ext : {"inp", "msh", "vtk"}) {
    INFO("hex." << ext);
    CHECK(got[ext]["groups"] == ref);
  }
  // each chart and patch group is one side of the box: its vertices lie within a hex edge (0.2) of one
  // plane (boundary quads at the box's edges fold across them, so not exactly on it); faces of two sides
  // would span at least the box's smallest size, 0.4, along every axis
  for (auto& [name, thickness] : got["msh"]["thickness"].items()) {
    INFO(name);
    if (name != "boundary") CHECK(thickness.get<double>() < 0.2);
  }
  for (const char* ext : {"e", "inp", "msh", "vtk", "mesh"})
    CHECK(run.report["nodes"][std::string("write_") + ext]["metrics"]["groups"] == 13);
  // Medit: one reference per face, the chart
  json charts = json::object();
  for (auto& [name, size] : ref.items())
    if (name.rfind("chart_", 0) == 0) charts[name] = size;
  CHECK(got["mesh"]["groups"] == charts);
  // node sets: Exodus and Abaqus give them to meshio as point_sets; the Gmsh quads' vertices agree
  const json& nodes = got["e"]["node_sets"];
  CHECK(nodes.size() == 13);
  CHECK(got["inp"]["node_sets"] == nodes);
  CHECK(got["msh"]["node_sets"] == nodes);
  // cell sets: Abaqus *ELSET volume; Gmsh one per physical group, the hexes in `volume`
  CHECK(got["inp"]["cell_sets"] == json{{"volume", hexes}});
  CHECK(got["msh"]["cell_sets"]["volume"] == hexes);
  CHECK(got["msh"]["cell_sets"]["boundary"] == faces);
}

TEST_CASE("clients: gmsh opens the .msh and writes it back with the hexes and the physical groups", "[io][clients]") {
  if (!client_available("gmsh --version", "gmsh (the Gmsh CLI)") || !meshio_available()) return;
  const BoxRun& run = box_run();
  const fs::path in = run.dir / "out" / "hex.msh", out = run.dir / "gmsh_back.msh";
  fs::remove(out);
  const CliRun r = run_command("gmsh -0 " + shell_quoted(in) + " -o " + shell_quoted(out) + " -format msh41 2>&1");
  INFO(r.out);
  REQUIRE(r.code == 0);
  REQUIRE(fs::exists(out));
  CHECK_THAT(polyhex::test::read_text(out), Catch::Matchers::Contains("$PhysicalNames"));
  const json before = read_back(in), after = read_back(out);
  CHECK(after["hexes"] == before["hexes"]);
  CHECK(after["min_jacobian"].get<double>() > 0);
  CHECK(after["groups"] == before["groups"]);
  CHECK(after["groups"].size() == 13);
  CHECK(after["cell_sets"]["volume"] == before["cell_sets"]["volume"]);
  CHECK(after["not_boundary"] == 0);
  CHECK(after["inward"] == 0);
}

TEST_CASE("clients: meshio finds every Exodus side, Abaqus face and quad of a grid's six sides", "[io][clients]") {
  if (!meshio_available()) return;
  // a 3 x 3 x 3 grid: its boundary faces use all six local faces, one side of the grid each
  const polyhex::HexMesh m = polyhex::iotest::hex_grid_with_side_groups(3);
  polyhex::iotest::TempDir dir;
  // (and the binary VTK writer, which the pipeline runs do not use, with the same groups)
  for (const char* name : {"grid.e", "grid.inp", "grid.msh", "grid.vtk"}) {
    INFO(name);
    polyhex::write_hexmesh(m, dir / name, std::string(name) == "grid.vtk" ? "vtk_binary" : "auto");
    const json r = read_back(dir / name);
    CHECK(r["hexes"] == 27);
    CHECK(r["min_jacobian"].get<double>() > 0);
    // a wrong side number names another face of the hex: an interior one, or one off its node set
    CHECK(r["not_boundary"] == 0);
    CHECK(r["outside_nodes"] == 0);
    CHECK(r["inward"] == 0);
    REQUIRE(r["groups"].size() == 7);
    CHECK(r["groups"]["boundary"] == 54);
    for (int s = 0; s < 6; ++s) {
      CHECK(r["groups"]["side_" + std::to_string(s)] == 9);
      if (std::string(name) != "grid.vtk") CHECK(r["node_sets"]["side_" + std::to_string(s)] == 16);
    }
  }
}
