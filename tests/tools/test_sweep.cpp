// `polyhex sweep` end to end (the binary): expansion of axes and named cases, strict validation with
// the sweep path in the message, sweep.csv / sweep.json / per-case folders, a failing case that does not
// stop the others. Correct with and without the artefact cache: cache hits are only compared with the
// cases' report.json, never required.
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <signal.h>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::read_text;
using polyhex::test::run_polyhex_to_files;

namespace {

// Runs `polyhex sweep ARGS` with stdout and stderr captured in files of `dir`.
CliRun sweep(const std::string& args, const fs::path& dir) {
  return run_polyhex_to_files("sweep " + args, dir / "stdout.txt", dir / "stderr.txt");
}

fs::path scratch(const std::string& name) { return polyhex::test::fresh_dir("sweep_" + name); }

std::string config(const std::string& name) { return std::string(POLYHEX_SOURCE_DIR) + "/configs/sweeps/" + name; }

// Coarse settings of the shipped sweep configs: each case is about a second.
const std::string kCoarse =
    " --set surface.resolution=24 --set tets.edge_length=0.08 --set quality.samples=5000 --threads 2";

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(p);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"')
        cell += '"', ++i;
      else if (c == '"')
        quoted = !quoted;
      else if (c == ',' && !quoted)
        cells.push_back(cell), cell.clear();
      else
        cell += c;
    }
    cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

size_t column(const std::vector<std::string>& header, const std::string& name) {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return i;
  FAIL("no column " << name);
  return 0;
}

// The unit cube of the I/O fixtures (quads, fan-triangulated by the reader): a fast input.
const std::string kCube = std::string(POLYHEX_SOURCE_DIR) + "/tests/fixtures/io/cube.off";

// Writes a sweep config on the split baseline of the cube (each case a fraction of a second).
fs::path baseline_sweep(const fs::path& dir, const json& sweep_value, const json& retry = nullptr) {
  json cfg = {{"sweep", sweep_value},
              {"nodes",
               {{{"id", "surface"}, {"type", "read_surface"}, {"params", {{"path", kCube}}}},
                {{"id", "tets"},
                 {"type", "tetrahedralize/tetgen"},
                 {"params", {{"edge_length", 0.12}}},
                 {"inputs", {{"surface", "surface"}}}},
                {{"id", "hex"}, {"type", "hex_from_tets/split"}, {"inputs", {{"tets", "tets"}}}},
                {{"id", "quality"},
                 {"type", "quality"},
                 {"params", {{"samples", 2000}}},
                 {"inputs", {{"mesh", "hex"}, {"surface", "surface"}}}}}}};
  if (!retry.is_null()) cfg["retry"] = retry;
  const fs::path p = dir / "sweep.config.json";
  std::ofstream(p) << cfg.dump(2);
  return p;
}

}  // namespace

TEST_CASE("sweep: axes expand to their cartesian product, last axis fastest", "[sweep]") {
  const fs::path dir = scratch("axes");
  CliRun r = sweep(config("rotation.json") + " --list", dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const json j = json::parse(r.out);
  CHECK(j["swept"] == json({"rotate.anchor_weight", "rotate.feature_angle"}));
  const json& cases = j["cases"];
  REQUIRE(cases.size() == 6);
  const double weights[] = {0.5, 0.5, 1, 1, 4, 4};
  const double angles[] = {45, 60, 45, 60, 45, 60};
  for (size_t c = 0; c < 6; ++c) {
    CHECK(cases[c]["set"].size() == 2);
    CHECK(cases[c]["set"]["rotate.anchor_weight"].get<double>() == weights[c]);
    CHECK(cases[c]["set"]["rotate.feature_angle"].get<double>() == angles[c]);
  }
  CHECK(cases[0]["name"] == "rotate.anchor_weight=0.5,rotate.feature_angle=45");
  CHECK(cases[5]["name"] == "rotate.anchor_weight=4,rotate.feature_angle=60");
  // With the cache every later case shares the tets with the first and waits for it; without, none waits.
  CHECK(cases[0]["depends_on"].is_null());
  for (size_t c = 1; c < 6; ++c) CHECK(cases[c]["depends_on"] == cases[0]["name"]);
  CliRun nc = sweep(config("rotation.json") + " --list --no-cache", dir);
  REQUIRE(nc.code == 0);
  // Named first: a range-for over json::parse(...)["cases"] would iterate a member of a temporary
  // that is destroyed before the loop runs (heap-use-after-free under ASan).
  const json listed = json::parse(nc.out);
  for (const json& c : listed["cases"]) CHECK(c["depends_on"].is_null());
}

TEST_CASE("sweep: a linked axis sets both params; named cases keep their order and sets", "[sweep]") {
  const fs::path dir = scratch("named");
  CliRun r = sweep(config("edge_length.json") + " --list", dir);
  REQUIRE(r.code == 0);
  json cases = json::parse(r.out)["cases"];
  REQUIRE(cases.size() == 3);
  const double h[] = {0.06, 0.045, 0.03};
  for (size_t c = 0; c < 3; ++c) {
    CHECK(cases[c]["set"]["polycube.edge_length"].get<double>() == h[c]);
    CHECK(cases[c]["set"]["segment.hex_edge_length"].get<double>() == h[c]);
  }
  CliRun n = sweep(config("rotation_cases.json") + " --list", dir);
  REQUIRE(n.code == 0);
  cases = json::parse(n.out)["cases"];
  REQUIRE(cases.size() == 4);
  CHECK(cases[0]["name"] == "paper");
  CHECK(cases[0]["set"] == json({{"rotate.flatten", 0}}));
  CHECK(cases[1]["name"] == "no_features");
  CHECK(cases[1]["set"] == json({{"rotate.feature_angle", 180}}));
  CHECK(cases[2]["set"] == json({{"rotate.anchor_weight", 10}}));
  CHECK(cases[3]["set"] == json({{"rotate.iterations", 2}}));
  CHECK(json::parse(n.out)["swept"] ==
        json({"rotate.flatten", "rotate.feature_angle", "rotate.anchor_weight", "rotate.iterations"}));
}

TEST_CASE("sweep: invalid sweeps are config errors naming the path (exit 2, nothing run)", "[sweep]") {
  const fs::path dir = scratch("errors");
  struct Bad {
    json sweep;
    std::string message;
  };
  const std::vector<Bad> bad = {
      {{{"nope.edge_length", {0.1}}},
       "sweep.\"nope.edge_length\": no node with id `nope`; ids: surface, tets, hex, quality"},
      {{{"tets.edge", {0.1}}},
       "sweep.\"tets.edge\": node `tets` (`tetrahedralize/tetgen`) has no param `edge`; params: edge_length"},
      {{{"tets.edge_length", {0.1, 7}}},
       "sweep.\"tets.edge_length\"[1] = 7: node `tets` (`tetrahedralize/tetgen`): param `edge_length`"},
      {{{"tets.edge_length", {0.1, 0.1}}}, "sweep.\"tets.edge_length\"[1]: value 0.1 is listed twice"},
      {{{"tets.edge_length", json::array()}}, "sweep.\"tets.edge_length\": an axis is a non-empty array of values"},
      {{{"tets.edge_length", 0.1}}, "sweep.\"tets.edge_length\": an axis is a non-empty array of values, got 0.1"},
      {{{"edge_length", {0.1}}}, "sweep.\"edge_length\": `edge_length` is not `<node id>.<param>`"},
      {json::object(), "sweep: an object of axes"},
      {{{"cases", {{{"name", "a"}, {"set", {{"tets.edge_length", 0.1}}}, {"note", 1}}}}},
       "sweep.cases[0]: unknown key `note`; valid keys: name, set"},
      {{{"cases", {{{"name", "a"}}, {{"name", "a"}}}}}, "sweep.cases[1]: duplicate case name `a`"},
      {{{"cases", {{{"name", "a/b"}}}}}, "sweep.cases[0]: case name `a/b` must use letters, digits"},
      {{{"cases", {{{"name", "a"}, {"set", {{"hex.x", 1}}}}}}},
       "sweep.cases[0].set.\"hex.x\": node `hex` (`hex_from_tets/split`) has no param `x`"},
      {{{"cases", {{{"name", "a"}, {"set", {{"quality.samples", "many"}}}}}}},
       "sweep.cases[0].set.\"quality.samples\" = \"many\": node `quality` (`quality/default`): param `samples`"},
      {{{"cases", json::array()}, {"tets.edge_length", {0.1}}}, "sweep: `cases` cannot be combined with axes"},
  };
  for (size_t k = 0; k < bad.size(); ++k) {
    const fs::path cfg = baseline_sweep(dir, bad[k].sweep);
    CliRun r = sweep(cfg.string() + " --out " + (dir / "out").string(), dir);
    INFO(k << ": " << bad[k].sweep.dump() << "\n" << r.err);
    CHECK(r.code == 2);
    CHECK_THAT(r.err, Contains(cfg.string() + ": " + bad[k].message));
    CHECK_FALSE(fs::exists(dir / "out" / "sweep.csv"));
  }
  // --set may not pin a swept param; a config without `sweep` is not a sweep.
  const fs::path cfg = baseline_sweep(dir, {{"tets.edge_length", {0.1, 0.2}}});
  CliRun s = sweep(cfg.string() + " --set tets.edge_length=0.3 --list", dir);
  CHECK(s.code == 2);
  CHECK_THAT(s.err, Contains("--set tets.edge_length=0.3: `tets.edge_length` is swept by " + cfg.string()));
  CliRun none = sweep(std::string(POLYHEX_SOURCE_DIR) + "/configs/baseline.json --list", dir);
  CHECK(none.code == 2);
  CHECK_THAT(none.err, Contains("baseline.json: no `sweep` key"));
}

TEST_CASE("sweep: the edge-length sweep writes sweep.csv, sweep.json and one folder per case", "[sweep]") {
  const fs::path dir = scratch("edge"), out = dir / "out";
  CliRun r = sweep(config("edge_length.json") + " --out " + out.string() + " --jobs 2" + kCoarse, dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const std::vector<std::string> names = {"polycube.edge_length+segment.hex_edge_length=0.06",
                                          "polycube.edge_length+segment.hex_edge_length=0.045",
                                          "polycube.edge_length+segment.hex_edge_length=0.03"};
  const std::vector<std::string> ids = {"surface", "tets",       "rotate",   "segment", "polycube", "hex",
                                        "pad",     "pad_peeled", "optimize", "quality", "write"};
  // CSV: header, one row per case in case order.
  auto rows = read_csv(out / "sweep.csv");
  REQUIRE(rows.size() == 4);
  std::vector<std::string> expected = {
      "case",   "status", "polycube.edge_length", "segment.hex_edge_length", "hexes",         "inverted",
      "sj_min", "sj_avg", "irregular_pct",        "hausdorff_mean",          "hausdorff_max", "seconds"};
  for (auto& id : ids) expected.push_back(id + ".seconds");
  for (auto& id : ids) expected.push_back(id + ".cache_hit");
  expected.push_back("exit_code");
  expected.push_back("error");
  CHECK(rows[0] == expected);
  const auto& h = rows[0];
  for (size_t c = 0; c < 3; ++c) {
    const auto& row = rows[c + 1];
    REQUIRE(row.size() == h.size());
    CHECK(row[column(h, "case")] == names[c]);
    CHECK(row[column(h, "status")] == "ok");
    CHECK(row[column(h, "polycube.edge_length")] == row[column(h, "segment.hex_edge_length")]);
    CHECK(row[column(h, "exit_code")] == "0");
    CHECK(row[column(h, "error")].empty());
  }
  // Finer hex edge, more hexes.
  auto hexes = [&](size_t c) { return std::stol(rows[c + 1][column(h, "hexes")]); };
  CHECK(hexes(0) > 100);
  CHECK(hexes(1) > hexes(0));
  CHECK(hexes(2) > hexes(1));

  // JSON: schema, cases with values, quality and per-node figures matching each case's report.json.
  const json s = json::parse(read_text(out / "sweep.json"));
  CHECK(s["schema"] == 1);
  CHECK(s["status"] == "ok");
  CHECK(s["failed"] == 0);
  CHECK(s["jobs"] == 2);
  CHECK(s["threads_per_case"] == 1);
  CHECK(s["quality_node"] == "quality");
  CHECK(s["swept"] == json({"polycube.edge_length", "segment.hex_edge_length"}));
  REQUIRE(s["cases"].size() == 3);
  for (size_t c = 0; c < 3; ++c) {
    const json& row = s["cases"][c];
    INFO(names[c]);
    CHECK(row["name"] == names[c]);
    CHECK(row["status"] == "ok");
    CHECK(row["values"]["polycube.edge_length"] == row["set"]["polycube.edge_length"]);
    const fs::path folder = out / names[c];
    REQUIRE(fs::exists(folder / "report.json"));
    CHECK(fs::exists(folder / "hex.vtk"));
    const json rep = json::parse(read_text(folder / "report.json"));
    CHECK(rep["status"] == "ok");
    CHECK(row["quality"]["hexes"] == rep["nodes"]["quality"]["metrics"]["hexes"]);
    CHECK(row["quality"]["sj_min"] == rep["nodes"]["quality"]["metrics"]["sj_min"]);
    CHECK(std::stol(rows[c + 1][column(h, "hexes")]) == row["quality"]["hexes"].get<long>());
    for (auto& id : ids) {
      CHECK(row["nodes"][id]["seconds"] == rep["nodes"][id]["seconds"]);
      CHECK(row["nodes"][id]["cache_hit"] == rep["nodes"][id]["cache_hit"]);
      CHECK(rows[c + 1][column(h, id + ".cache_hit")] == rep["nodes"][id]["cache_hit"].dump());
    }
    // The first case finds an empty cache.
    if (c == 0)
      for (auto& id : ids) CHECK(row["nodes"][id]["cache_hit"] == false);
    // config.json is the resolved case: `polyhex run` on it repeats the case.
    const json cfg = json::parse(read_text(folder / "config.json"));
    CHECK_FALSE(cfg.contains("sweep"));
    for (const json& n : cfg["nodes"])
      if (n["id"] == "polycube") CHECK(n["params"]["edge_length"] == row["set"]["polycube.edge_length"]);
  }
  // The terminal table lists every case.
  for (auto& n : names) CHECK_THAT(r.out, Contains(n));
}

TEST_CASE("sweep: the anchor-weight x feature-angle sweep runs every case", "[sweep]") {
  const fs::path dir = scratch("rotation"), out = dir / "out";
  CliRun r = sweep(config("rotation.json") + " --out " + out.string() + " --jobs 2" + kCoarse +
                       " --set segment.hex_edge_length=0.06 --set polycube.edge_length=0.06",
                   dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const json s = json::parse(read_text(out / "sweep.json"));
  REQUIRE(s["cases"].size() == 6);
  for (const json& row : s["cases"]) {
    INFO(row["name"]);
    CHECK(row["status"] == "ok");
    CHECK(row["quality"]["hexes"].get<int>() > 100);
    CHECK(row["values"]["rotate.anchor_weight"] == row["set"]["rotate.anchor_weight"]);
    const json rep = json::parse(read_text(out / row["name"].get<std::string>() / "report.json"));
    // the swept values reached the node (its canonical params are not in the report; its config is)
    const json cfg = json::parse(read_text(out / row["name"].get<std::string>() / "config.json"));
    for (const json& n : cfg["nodes"])
      if (n["id"] == "rotate") {
        CHECK(n["params"]["anchor_weight"] == row["set"]["rotate.anchor_weight"]);
        CHECK(n["params"]["feature_angle"] == row["set"]["rotate.feature_angle"]);
      }
    CHECK(rep["nodes"]["rotate"]["metrics"]["iterations"] == 5);
  }
  CHECK(read_csv(out / "sweep.csv").size() == 7);
}

TEST_CASE("sweep: a failing case is reported, the others still run, the exit code says so", "[sweep]") {
  const fs::path dir = scratch("failing"), out = dir / "out";
  const fs::path cfg =
      baseline_sweep(dir, {{"cases",
                            {{{"name", "box"}, {"set", json::object()}},
                             {{"name", "missing"}, {"set", {{"surface.path", "/nonexistent/part.off"}}}},
                             {{"name", "coarser"}, {"set", {{"tets.edge_length", 0.2}}}}}}});
  // A report left by an earlier sweep in the failing case's folder must not pass for this run's.
  fs::create_directories(out / "missing");
  std::ofstream(out / "missing" / "report.json") << R"({"status": "ok", "nodes": {}})";
  CliRun r = sweep(cfg.string() + " --out " + out.string() + " --jobs 2 --threads 2", dir);
  INFO(r.err);
  CHECK(r.code == 1);
  const json s = json::parse(read_text(out / "sweep.json"));
  CHECK(s["status"] == "failed");
  CHECK(s["failed"] == 1);
  REQUIRE(s["cases"].size() == 3);
  const json& ok1 = s["cases"][0];
  const json& bad = s["cases"][1];
  const json& ok2 = s["cases"][2];
  CHECK(ok1["status"] == "ok");
  CHECK(ok2["status"] == "ok");
  CHECK(ok1["quality"]["hexes"].get<int>() > ok2["quality"]["hexes"].get<int>());  // 0.12 vs 0.2 tet edge
  CHECK(ok1["quality"]["inverted"] == 0);
  CHECK(bad["status"] == "error");
  CHECK(bad["exit_code"] == 1);
  CHECK_THAT(bad["error"].get<std::string>(), Contains("surface"));
  CHECK_THAT(bad["error"].get<std::string>(), Contains("/nonexistent/part.off"));
  CHECK(bad["quality"].is_null());
  CHECK(bad["nodes"]["surface"]["ran"] == false);
  CHECK(bad["nodes"]["tets"]["ran"] == false);
  const json rep = json::parse(read_text(out / "missing" / "report.json"));
  CHECK(rep["status"] == "error");
  auto rows = read_csv(out / "sweep.csv");
  REQUIRE(rows.size() == 4);
  const auto& h = rows[0];
  CHECK(rows[2][column(h, "status")] == "error");
  CHECK(rows[2][column(h, "hexes")].empty());
  CHECK_THAT(rows[2][column(h, "error")], Contains("/nonexistent/part.off"));
  CHECK(rows[1][column(h, "surface.path")] == kCube);
  CHECK(rows[1][column(h, "tets.edge_length")] == "0.12");  // effective value of a case that sets nothing
  CHECK(rows[3][column(h, "tets.edge_length")] == "0.2");
  CHECK_THAT(r.err, Contains("3 cases: 1 error, 2 ok"));
}

TEST_CASE("sweep: SIGTERM stops the running cases at a safe point, starts no more, writes the summary", "[sweep]") {
  const fs::path dir = scratch("interrupt"), out = dir / "out";
  const std::string first = "rotate.anchor_weight=0.5,rotate.feature_angle=45";
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::freopen((dir / "stderr.txt").c_str(), "w", stderr);
    std::freopen((dir / "stdout.txt").c_str(), "w", stdout);
    ::execl(POLYHEX_BINARY, POLYHEX_BINARY, "sweep", config("rotation.json").c_str(), "--out", out.c_str(), "--jobs",
            "1", "--threads", "1", "--set", "surface.resolution=24", "--set", "tets.edge_length=0.06",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait until the first case runs, then stop the sweep (its children are in their own process group).
  for (int k = 0; k < 300 && !fs::exists(out / first / "log.txt"); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(pid, SIGTERM);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  const std::string err = read_text(dir / "stderr.txt");
  INFO(err);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  const json s = json::parse(read_text(out / "sweep.json"));
  CHECK(s["status"] == "interrupted");
  REQUIRE(s["cases"].size() == 6);
  CHECK(s["cases"][0]["status"] == "interrupted");
  CHECK_THAT(s["cases"][0]["error"].get<std::string>(), Contains("interrupted by SIGTERM"));
  for (size_t c = 1; c < 6; ++c) {
    CHECK(s["cases"][c]["status"] == "not_run");
    CHECK_FALSE(fs::exists(out / s["cases"][c]["name"].get<std::string>()));
  }
  CHECK_THAT(err, Contains("interrupted; 6 cases: 1 interrupted, 5 not_run"));
}

TEST_CASE("sweep: every case follows the config's retry block, on top of its own values", "[sweep]") {
  const fs::path dir = scratch("retry"), out = dir / "out";
  // never accepted: each case runs its own config, then the variant (quality sampled differently)
  const json retry = {{"node", "quality"}, {"min_sj", 1.0}, {"variants", {{{"quality.samples", 1000}}}}};
  const fs::path cfg = baseline_sweep(dir, {{"tets.edge_length", {0.12, 0.2}}}, retry);
  CliRun r = sweep(cfg.string() + " --out " + out.string() + " --jobs 1 --threads 2", dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const json s = json::parse(read_text(out / "sweep.json"));
  REQUIRE(s["cases"].size() == 2);
  int hexes[2];
  for (int c = 0; c < 2; ++c) {
    const std::string name = s["cases"][c]["name"].get<std::string>();
    const json rep = json::parse(read_text(out / name / "report.json"));
    REQUIRE(rep["retry"]["attempts"].size() == 2);
    CHECK(rep["retry"]["attempts"][1]["set"]["quality.samples"] == 1000);
    hexes[c] = rep["nodes"]["quality"]["metrics"]["hexes"].get<int>();
    for (auto& e : fs::directory_iterator(out / name)) CHECK(e.path().filename().string().rfind(".retry", 0) != 0);
  }
  CHECK(hexes[0] > hexes[1]);  // each case kept its own tet edge (0.12 vs 0.2) through the retry
  // a bad variant is refused before anything runs, naming the case
  const fs::path bad = baseline_sweep(dir, {{"tets.edge_length", {0.12}}},
                                      {{"node", "quality"}, {"variants", {{{"quality.sampels", 1}}}}});
  CliRun b = sweep(bad.string() + " --out " + (dir / "bad").string(), dir);
  CHECK(b.code == 2);
  CHECK_THAT(b.err, Contains("retry.variants[0]") && Contains("sampels"));
}
