// End-to-end runs of the polyhex binary: exit codes, messages naming file/node, report.json, check vs run.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/helpers/cli.h"

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::run_polyhex;

namespace {

std::string config(const std::string& name) { return std::string(POLYHEX_SOURCE_DIR) + "/configs/" + name; }

}  // namespace

TEST_CASE("cli: the default (PolyCube) config meshes a built-in shape with no inverted hex", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_polycube");
  CliRun r = run_polyhex("run " + config("default.json") + " --out " + out.string() +
                 " --set tets.edge_length=0.04 --set segment.hex_edge_length=0.03 --set polycube.edge_length=0.03 --threads 2");
  INFO(r.out);
  REQUIRE(r.code == 0);
  std::ifstream in(out / "report.json");
  json rep = json::parse(in);
  const json& q = rep["nodes"]["quality"]["metrics"];
  CHECK(q["inverted"] == 0);
  CHECK(q["hexes"].get<int>() > 1000);
  CHECK(q["sj_min"].get<double>() > 0.2);
  CHECK(q["irregular_pct"].get<double>() < 10.0);  // the split baseline is ~90 %
  CHECK(q["nonmanifold_boundary_edges"] == 0);
  CHECK(rep["nodes"]["rotate"]["metrics"]["factorizations"] == 2);
  CHECK(rep["nodes"]["segment"]["metrics"]["valid"] == true);
}

TEST_CASE("cli: the baseline config runs on a built-in shape; check agrees with the report", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_default");
  CliRun r = run_polyhex("run " + config("baseline.json") + " --out " + out.string() + " --set tets.edge_length=0.08 --threads 2");
  INFO(r.out);
  REQUIRE(r.code == 0);
  std::ifstream in(out / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "ok");
  for (auto id : {"surface", "tets", "hex", "quality", "write"}) CHECK(rep["nodes"][id]["ran"] == true);
  const json& q = rep["nodes"]["quality"]["metrics"];
  CHECK(q["inverted"] == 0);
  CHECK(q["hexes"].get<int>() == 4 * rep["nodes"]["tets"]["metrics"]["tets"].get<int>());
  REQUIRE(fs::exists(out / "hex.vtk"));
  // no temporary file is left behind
  for (auto& e : fs::directory_iterator(out)) CHECK(e.path().string().find(".tmp.") == std::string::npos);
  CliRun c = run_polyhex("check " + (out / "hex.vtk").string() + " --json");
  INFO(c.out);
  REQUIRE(c.code == 0);
  json cj = json::parse(c.out);
  CHECK(cj["hexes"] == q["hexes"]);
  CHECK(cj["sj_min"].get<double>() == Approx(q["sj_min"].get<double>()).margin(1e-12));
  CHECK(cj["sj_avg"].get<double>() == Approx(q["sj_avg"].get<double>()).margin(1e-12));
  CHECK(cj["irregular_pct"].get<double>() == Approx(q["irregular_pct"].get<double>()).margin(1e-12));
}

TEST_CASE("cli: bad input names the file and the node, exits non-zero, writes no mesh", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_bad");
  std::ofstream(out / "open.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CliRun r = run_polyhex("run " + config("baseline.json") + " --input " + (out / "open.off").string() + " --out " + (out / "o").string());
  INFO(r.out);
  CHECK(r.code == 1);
  CHECK_THAT(r.out, Contains("node `surface` (`read_surface/default`)") && Contains("open.off"));
  CHECK_FALSE(fs::exists(out / "o" / "hex.vtk"));
  std::ifstream in(out / "o" / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "error");

  CliRun m = run_polyhex("run " + config("baseline.json") + " --input " + (out / "missing.stl").string() + " --out " + (out / "o2").string());
  CHECK(m.code == 1);
  CHECK_THAT(m.out, Contains("missing.stl"));
}

TEST_CASE("cli: config errors exit 2 with the node named", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_cfg");
  CliRun r = run_polyhex("run " + config("default.json") + " --set tets.edge_lenght=0.1 --out " + out.string());
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Contains("node `tets`") && Contains("unknown param `edge_lenght`"));
  CliRun s = run_polyhex("run " + config("default.json") + " --set nowhere.x=1 --out " + out.string());
  CHECK(s.code == 2);
  CHECK_THAT(s.out, Contains("no node with id `nowhere`"));
  CliRun u = run_polyhex("frobnicate");
  CHECK(u.code != 0);
}

TEST_CASE("cli: graph prints DOT, nodes lists the registry, shapes writes a surface", "[cli]") {
  CliRun g = run_polyhex("graph " + config("polycube.json"));
  REQUIRE(g.code == 0);
  CHECK_THAT(g.out, Contains("digraph polyhex") && Contains("\"rotate\" -> \"segment\""));
  CliRun n = run_polyhex("nodes --json");
  REQUIRE(n.code == 0);
  json nj = json::parse(n.out);
  CHECK(nj.contains("rotation_deform/quaternion_laplace"));
  CHECK(nj["tetrahedralize/tetgen"]["inputs"][0]["type"] == "SurfaceMesh");
  fs::path out = polyhex::test::fresh_dir("cli_shapes");
  CliRun s = run_polyhex("shapes torus --out " + (out / "torus.obj").string());
  INFO(s.out);
  REQUIRE(s.code == 0);
  CHECK(fs::file_size(out / "torus.obj") > 1000);
  CliRun bad = run_polyhex("shapes teapot --out " + (out / "t.obj").string());
  CHECK(bad.code == 1);
  CHECK_THAT(bad.out, Contains("teapot"));
}
