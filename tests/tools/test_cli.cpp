// End-to-end runs of the polyhex binary: exit codes, messages naming file/node, report.json, check vs run.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;

namespace {

struct Result {
  int code;
  std::string output;  // stdout and stderr together
};

Result run(const std::string& args) {
  std::string cmd = std::string(POLYHEX_BINARY) + " " + args + " 2>&1";
  Result r{-1, {}};
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

fs::path temp_dir(const std::string& name) {
  auto d = fs::temp_directory_path() / ("polyhex_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string config(const std::string& name) { return std::string(POLYHEX_SOURCE_DIR) + "/configs/" + name; }

}  // namespace

TEST_CASE("cli: the default (PolyCube) config meshes a built-in shape with no inverted hex", "[cli]") {
  fs::path out = temp_dir("polycube");
  Result r = run("run " + config("default.json") + " --out " + out.string() +
                 " --set tets.edge_length=0.04 --set segment.hex_edge_length=0.03 --set polycube.edge_length=0.03 --threads 2");
  INFO(r.output);
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
  fs::path out = temp_dir("default");
  Result r = run("run " + config("baseline.json") + " --out " + out.string() + " --set tets.edge_length=0.08 --threads 2");
  INFO(r.output);
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
  Result c = run("check " + (out / "hex.vtk").string() + " --json");
  INFO(c.output);
  REQUIRE(c.code == 0);
  json cj = json::parse(c.output);
  CHECK(cj["hexes"] == q["hexes"]);
  CHECK(cj["sj_min"].get<double>() == Approx(q["sj_min"].get<double>()).margin(1e-12));
  CHECK(cj["sj_avg"].get<double>() == Approx(q["sj_avg"].get<double>()).margin(1e-12));
  CHECK(cj["irregular_pct"].get<double>() == Approx(q["irregular_pct"].get<double>()).margin(1e-12));
}

TEST_CASE("cli: bad input names the file and the node, exits non-zero, writes no mesh", "[cli]") {
  fs::path out = temp_dir("bad");
  std::ofstream(out / "open.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  Result r = run("run " + config("baseline.json") + " --input " + (out / "open.off").string() + " --out " + (out / "o").string());
  INFO(r.output);
  CHECK(r.code == 1);
  CHECK_THAT(r.output, Contains("node `surface` (`read_surface/default`)") && Contains("open.off"));
  CHECK_FALSE(fs::exists(out / "o" / "hex.vtk"));
  std::ifstream in(out / "o" / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "error");

  Result m = run("run " + config("baseline.json") + " --input " + (out / "missing.stl").string() + " --out " + (out / "o2").string());
  CHECK(m.code == 1);
  CHECK_THAT(m.output, Contains("missing.stl"));
}

TEST_CASE("cli: config errors exit 2 with the node named", "[cli]") {
  fs::path out = temp_dir("cfg");
  Result r = run("run " + config("default.json") + " --set tets.edge_lenght=0.1 --out " + out.string());
  CHECK(r.code == 2);
  CHECK_THAT(r.output, Contains("node `tets`") && Contains("unknown param `edge_lenght`"));
  Result s = run("run " + config("default.json") + " --set nowhere.x=1 --out " + out.string());
  CHECK(s.code == 2);
  CHECK_THAT(s.output, Contains("no node with id `nowhere`"));
  Result u = run("frobnicate");
  CHECK(u.code != 0);
}

TEST_CASE("cli: graph prints DOT, nodes lists the registry, shapes writes a surface", "[cli]") {
  Result g = run("graph " + config("polycube.json"));
  REQUIRE(g.code == 0);
  CHECK_THAT(g.output, Contains("digraph polyhex") && Contains("\"rotate\" -> \"segment\""));
  Result n = run("nodes --json");
  REQUIRE(n.code == 0);
  json nj = json::parse(n.output);
  CHECK(nj.contains("rotation_deform/quaternion_laplace"));
  CHECK(nj["tetrahedralize/tetgen"]["inputs"][0]["type"] == "SurfaceMesh");
  fs::path out = temp_dir("shapes");
  Result s = run("shapes torus --out " + (out / "torus.obj").string());
  INFO(s.output);
  REQUIRE(s.code == 0);
  CHECK(fs::file_size(out / "torus.obj") > 1000);
  Result bad = run("shapes teapot --out " + (out / "t.obj").string());
  CHECK(bad.code == 1);
  CHECK_THAT(bad.output, Contains("teapot"));
}
