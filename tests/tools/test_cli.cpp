// End-to-end runs of the polyhex binary: exit codes, messages naming file/node, report.json, check vs run.
#include "graph/stat_metrics.h"
#include "nodes/boundary_groups/boundary_groups.h"
#include "nodes/hex_extract/hex_extract.h"
#include "nodes/optimize/optimize.h"
#include "nodes/orient/orient.h"
#include "nodes/pad/pad.h"
#include "nodes/position_deform/position_deform.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "tests/helpers/cli.h"
#include "tests/helpers/report.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::run_polyhex;

namespace {

std::string config(const std::string& name) { return std::string(POLYHEX_SOURCE_DIR) + "/configs/" + name; }

/// Every key (and member of an object) of `expected` is in `metrics`.
void check_keys(const json& expected, const json& metrics, const std::string& where) {
  for (const auto& [key, value] : expected.items()) {
    INFO(where << ": " << key);
    REQUIRE(metrics.contains(key));
    if (value.is_object()) check_keys(value, metrics[key], where + "." + key);
  }
}

/// Every figure the stats struct S declares (runtime/stat_fields.h) is in the node's metrics.
template <class S>
void check_declared(const json& node, const std::string& where) {
  json expected;
  polyhex::put_stats(S{}, expected);
  REQUIRE(!expected.empty());
  check_keys(expected, node["metrics"], where);
}

}  // namespace

TEST_CASE("cli: the default (PolyCube) config meshes a built-in shape with no inverted hex", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_polycube");
  CliRun r = run_polyhex(
      "run " + config("default.json") + " --out " + out.string() +
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
  CHECK(polyhex::test::kept_node(rep, "rotate")["metrics"]["factorizations"] == 2);
  CHECK(polyhex::test::kept_node(rep, "segment")["metrics"]["valid"] == true);
  // Each stage reports every figure its stats declare, the map's untangling rounds among them.
  using polyhex::test::kept_node;
  check_declared<polyhex::TetgenStats>(rep["nodes"]["tets"], "tets");
  check_declared<polyhex::OrientStats>(rep["nodes"]["orient"], "orient");
  check_declared<polyhex::RotationDeformResult>(kept_node(rep, "rotate"), "rotate");
  check_declared<polyhex::PositionDeformStats>(kept_node(rep, "polycube"), "polycube");
  check_declared<polyhex::HexExtractStats>(kept_node(rep, "hex"), "hex");
  check_declared<polyhex::PadStats>(kept_node(rep, "pad"), "pad");
  check_declared<polyhex::OptimizeStats>(kept_node(rep, "optimize"), "optimize");
  check_declared<polyhex::BoundaryGroupsStats>(kept_node(rep, "groups"), "groups");
  const json map = kept_node(rep, "polycube")["metrics"];
  if (map["inverted_tets_before_untangle"].get<long>() > 0) CHECK(map["untangle_rounds"].get<int>() >= 1);
  CHECK(kept_node(rep, "rotate")["metrics"]["solve_mode"] == "multi_column");
  CHECK(kept_node(rep, "rotate")["metrics"]["alignment"].size() == 5);  // one per iteration
}

TEST_CASE("cli: the baseline config runs on a built-in shape; check agrees with the report", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_default");
  CliRun r = run_polyhex("run " + config("baseline.json") + " --out " + out.string() +
                         " --set tets.edge_length=0.08 --threads 2");
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
  CliRun r = run_polyhex("run " + config("baseline.json") + " --input " + (out / "open.off").string() + " --out " +
                         (out / "o").string());
  INFO(r.out);
  CHECK(r.code == 1);
  // the baseline has no conditioning: the reader passes the open surface on, TetGen's node refuses it
  CHECK_THAT(r.out, Contains("node `tets` (`tetrahedralize/tetgen`)") && Contains("open.off"));
  CHECK_FALSE(fs::exists(out / "o" / "hex.vtk"));
  std::ifstream in(out / "o" / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "error");

  CliRun m = run_polyhex("run " + config("baseline.json") + " --input " + (out / "missing.stl").string() + " --out " +
                         (out / "o2").string());
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
  CHECK_THAT(g.out, Contains("digraph polyhex") && Contains("\"rotate#1\" -> \"segment#1\""));
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

namespace {

/// baseline.json with a `retry` block.
fs::path retry_config(const fs::path& dir, const json& retry) {
  std::ifstream in(config("baseline.json"));
  json j = json::parse(in);
  j["retry"] = retry;
  fs::path p = dir / "retry.json";
  std::ofstream(p) << j.dump(2);
  return p;
}

}  // namespace

TEST_CASE("cli: a run whose every orientation branch fails tries the retry variants", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_retry_branches");
  // the map refuses in every branch (more hexes than max_hexes): the input was read and meshed, no frame was
  auto cfg = [&](const json& variants, const json& on_failure = json::array()) {
    std::ifstream in(config("default.json"));
    json j = json::parse(in);
    for (auto& n : j["nodes"])
      if (n["id"] == "polycube") n["params"]["max_hexes"] = 1000;
    j["retry"]["variants"] = variants;
    j["retry"]["on_failure"] = on_failure;
    fs::path p = out / "branches.json";
    std::ofstream(p) << j.dump(2);
    return p.string();
  };
  CliRun r = run_polyhex("run " + cfg(json::array({{{"polycube.max_hexes", 2e7}}})) + " --out " + (out / "o").string() +
                         " --hex-edge 0.035 --threads 2");
  INFO(r.out);
  REQUIRE(r.code == 0);
  std::ifstream in(out / "o" / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "ok");
  const json& att = rep["retry"]["attempts"];
  REQUIRE(att.size() == 2);
  CHECK(att[0]["status"] == "error");
  CHECK(att[0]["accepted"] == false);
  CHECK(att[1]["status"] == "ok");
  CHECK(rep["retry"]["chosen"] == 1);
  CHECK(rep["nodes"]["quality"]["metrics"]["inverted"] == 0);
  CHECK(fs::exists(out / "o" / "hex.vtk"));
  // on_failure variants run after the others, while no attempt has made a mesh
  CliRun o = run_polyhex(
      "run " + cfg(json::array({{{"polycube.distance_weight", 2.0}}}), json::array({{{"polycube.max_hexes", 2e7}}})) +
      " --out " + (out / "of").string() + " --hex-edge 0.035 --threads 2");
  INFO(o.out);
  REQUIRE(o.code == 0);
  std::ifstream oin(out / "of" / "report.json");
  const json orep = json::parse(oin);
  CHECK(orep["retry"]["attempts"].size() == 3);
  CHECK(orep["retry"]["chosen"] == 2);
  // no variant helps: the first run's error, a non-zero exit and no mesh
  CliRun f = run_polyhex("run " + cfg(json::array({{{"polycube.distance_weight", 2.0}}})) + " --out " +
                         (out / "f").string() + " --hex-edge 0.035 --threads 2");
  INFO(f.out);
  CHECK(f.code != 0);
  CHECK_THAT(f.out, Contains("node `best`"));
  CHECK_FALSE(fs::exists(out / "f" / "hex.vtk"));
  std::ifstream fin(out / "f" / "report.json");
  json frep = json::parse(fin);
  CHECK(frep["status"] == "error");
  CHECK(frep["retry"]["attempts"].size() == 2);
}

TEST_CASE("cli: retry runs the variants while no attempt is accepted and keeps the best", "[cli]") {
  fs::path out = polyhex::test::fresh_dir("cli_retry");
  SECTION("never accepted: every variant runs, the best attempt's mesh and report are kept") {
    fs::path cfg = retry_config(out, {{"node", "quality"},
                                      {"min_sj", 1.0},
                                      {"variants", {{{"tets.edge_length", 0.1}}, {{"tets.edge_length", 0.12}}}},
                                      {"on_failure", {{{"tets.edge_length", 0.14}}}}});  // meshes were made: not run
    CliRun r = run_polyhex("run " + cfg.string() + " --out " + (out / "o").string() +
                           " --set tets.edge_length=0.08 --no-cache --threads 2");
    INFO(r.out);
    REQUIRE(r.code == 0);
    std::ifstream in(out / "o" / "report.json");
    json rep = json::parse(in);
    const json& att = rep["retry"]["attempts"];
    REQUIRE(att.size() == 3);
    int best = 0;
    for (int k = 0; k < 3; ++k) {
      CHECK(att[k]["accepted"] == false);
      CHECK(att[k]["inverted"] == 0);
      if (att[k]["sj_min"].get<double>() > att[best]["sj_min"].get<double>()) best = k;
    }
    CHECK(att[1]["set"]["tets.edge_length"] == 0.1);
    CHECK(rep["retry"]["chosen"] == best);
    CHECK(rep["retry"]["min_sj"] == 1.0);  // the thresholds that judged the attempts (the HTML report shows them)
    CHECK(rep["retry"]["max_inverted"] == 0);
    const json& q = rep["nodes"]["quality"]["metrics"];
    CHECK(q["sj_min"].get<double>() == att[best]["sj_min"].get<double>());
    // the written mesh is the chosen attempt's
    CliRun c = run_polyhex("check " + (out / "o" / "hex.vtk").string() + " --json");
    REQUIRE(c.code == 0);
    json cj = json::parse(c.out);
    CHECK(cj["hexes"] == q["hexes"]);
    CHECK(cj["sj_min"].get<double>() == Approx(q["sj_min"].get<double>()).margin(1e-12));
    // the attempts' folders and the temporary cache are gone
    for (auto& e : fs::directory_iterator(out / "o")) CHECK(e.path().filename().string().rfind(".retry", 0) != 0);
    CHECK(rep["seconds"].get<double>() >= att[0]["seconds"].get<double>() + att[1]["seconds"].get<double>());
  }
  SECTION("with the default cache the attempts share the cache beside OUT") {
    fs::path cfg =
        retry_config(out, {{"node", "quality"}, {"min_sj", 1.0}, {"variants", {{{"tets.edge_length", 0.12}}}}});
    CliRun r = run_polyhex("run " + cfg.string() + " --out " + (out / "c").string() +
                           " --set tets.edge_length=0.1 --threads 2");
    INFO(r.out);
    REQUIRE(r.code == 0);
    CHECK(fs::exists(out / ".polyhex-cache"));
    CHECK_FALSE(fs::exists(out / "c" / ".polyhex-cache"));
    std::ifstream in(out / "c" / "report.json");
    CHECK(json::parse(in)["retry"]["attempts"].size() == 2);
  }
  SECTION("accepted at once: no variant runs") {
    fs::path cfg =
        retry_config(out, {{"node", "quality"}, {"min_sj", 0.0}, {"variants", {{{"tets.edge_length", 0.1}}}}});
    CliRun r = run_polyhex("run " + cfg.string() + " --out " + (out / "a").string() +
                           " --set tets.edge_length=0.1 --threads 2");
    INFO(r.out);
    REQUIRE(r.code == 0);
    std::ifstream in(out / "a" / "report.json");
    json rep = json::parse(in);
    CHECK(rep["retry"]["attempts"].size() == 1);
    CHECK(rep["retry"]["attempts"][0]["accepted"] == true);
    CHECK(rep["retry"]["chosen"] == 0);
  }
  SECTION("a bad block is a config error naming the key, before anything runs") {
    auto fails = [&](const json& block, const std::string& says) {
      fs::path cfg = retry_config(out, block);
      CliRun r = run_polyhex("run " + cfg.string() + " --out " + (out / "bad").string());
      INFO(r.out);
      CHECK(r.code == 2);
      CHECK_THAT(r.out, Contains(says));
      CHECK_FALSE(fs::exists(out / "bad" / "hex.vtk"));
    };
    fails({{"node", "quality"}, {"variants", {{{"tets.edge_length", 0.1}}}}, {"min_sjj", 0.3}},
          "unknown key `min_sjj`");
    fails({{"node", "nowhere"}, {"variants", {{{"tets.edge_length", 0.1}}}}}, "retry.node: no node with id `nowhere`");
    fails({{"node", "quality"}, {"variants", {{{"tets.edge_lenght", 0.1}}}}}, "retry.variants[0]");
    fails({{"node", "quality"}, {"variants", json::array()}}, "`variants` must be a non-empty array");
    fails({{"node", "quality"}, {"min_sj", 2}, {"variants", {{{"tets.edge_length", 0.1}}}}}, "retry.min_sj");
    fails({{"node", "quality"}, {"variants", {{{"tets.edge_length", 0.1}}}}, {"on_failure", {{{"tets.x", 1}}}}},
          "retry.on_failure[0]");
  }
}
