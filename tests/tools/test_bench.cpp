// `polyhex bench` end to end (the binary): the JSON schema, repeat counts, min <= median <= max,
// throughput in each node's unit, the factorization figures, and a failing run.
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::run_polyhex_to_files;

namespace {

// Runs `polyhex bench ARGS` in a fresh folder `dir`; stdout and stderr go to files there.
CliRun bench(const std::string& args, const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  return run_polyhex_to_files("bench " + args + " --out '" + (dir / "runs").string() + "'", dir / "out.txt",
                              dir / "err.txt");
}

fs::path bench_dir(const std::string& name) {
  return fs::temp_directory_path() / ("polyhex_bench_" + name + "_" + std::to_string(::getpid()));
}

void check_stats(const json& s, size_t n) {
  REQUIRE(s["seconds"].size() == n);
  const double lo = s["min"], mid = s["median"], hi = s["max"];
  CHECK(lo <= mid);
  CHECK(mid <= hi);
  for (const json& t : s["seconds"]) {
    CHECK(t.get<double>() >= lo);
    CHECK(t.get<double>() <= hi);
  }
}

}  // namespace

TEST_CASE("bench: the throughput config, coarse: JSON schema, units, solver figures", "[bench]") {
  const fs::path dir = bench_dir("schema");
  const std::string config = std::string(POLYHEX_SOURCE_DIR) + "/configs/bench/throughput_200k.json";
  CliRun r = bench(config +
                       " --set surface.resolution=24 --set tets.edge_length=0.08 --set segment.hex_edge_length=0.06"
                       " --set polycube.edge_length=0.06 --set quality.samples=5000 --threads 2 --repeat 3 --warmup 1"
                       " --json " +
                       (dir / "bench.json").string(),
                   dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const json b = json::parse(std::ifstream(dir / "bench.json"));
  CHECK(b["schema"] == 1);
  CHECK(b["kind"] == "polyhex-bench");
  CHECK(b["repeat"] == 3);
  CHECK(b["warmup"] == 1);
  CHECK(b["cache"] == false);
  CHECK(b["threads"] == 2);
  CHECK(b["config"] == config);
  CHECK(b["sets"].size() == 5);
  check_stats(b["total"], 3);
  REQUIRE(b["units"].is_object());
  CHECK(b["units"]["tetrahedralize"].get<std::string>().rfind("tets/s", 0) == 0);

  const char* ids[] = {"surface", "tets",       "rotate",   "segment", "polycube", "hex",
                       "pad",     "pad_peeled", "optimize", "quality", "write"};
  const char* units[] = {"triangles/s", "tets/s",  "tets/s",  "triangles/s", "tets/s", "hexes/s",
                         "hexes/s",     "hexes/s", "hexes/s", "hexes/s",     "hexes/s"};
  REQUIRE(b["nodes"].size() == 11);
  std::map<std::string, json> by_id;
  for (size_t i = 0; i < 11; ++i) {
    const json& n = b["nodes"][i];
    INFO(ids[i]);
    CHECK(n["id"] == ids[i]);  // config order
    check_stats(n, 3);
    CHECK(n["unit"] == units[i]);
    REQUIRE(n["count"].is_object());
    CHECK(n["count"]["value"].get<double>() > 0);
    CHECK(n["throughput"].get<double>() > 0);
    CHECK(n["throughput"].get<double>() == Approx(n["count"]["value"].get<double>() / n["median"].get<double>()));
    CHECK(n["rss_mb"].get<double>() > 0);
    CHECK(n["rss_mb"].get<double>() <= b["peak_rss_mb"].get<double>());
    by_id[ids[i]] = n;
    CHECK_THAT(r.out, Contains(ids[i]));  // a table row per node
  }
  // Sizes come from the node itself or the producer of the named input.
  const double tets = by_id["tets"]["metrics"]["tets"];
  CHECK(by_id["tets"]["count"]["value"] == tets);
  CHECK(by_id["rotate"]["count"]["value"] == tets);
  CHECK(by_id["polycube"]["count"] == json({{"metric", "tets"}, {"node", "tets"}, {"value", tets}}));
  const double hexes = by_id["quality"]["metrics"]["hexes"];
  CHECK(by_id["optimize"]["count"]["value"] == hexes);  // optimize keeps the hexes of its input
  CHECK(by_id["write"]["count"]["value"] == hexes);
  CHECK(by_id["pad"]["count"]["value"] == hexes);
  // The factorization helper's figures of the rotation stage (both systems factored once).
  const json& s = by_id["rotate"]["solver"];
  REQUIRE(s.is_object());
  CHECK(s["factorizations"] == 2);
  CHECK(s["solves"].get<int>() > 0);
  check_stats(s["factor_seconds"], 3);
  check_stats(s["solve_seconds"], 3);
  CHECK(s["factor_seconds_each"].get<double>() == Approx(s["factor_seconds"]["median"].get<double>() / 2));
  CHECK(s["solves_per_second"].get<double>() > 0);
  CHECK_FALSE(by_id["hex"].contains("solver"));
  CHECK_THAT(r.out, Contains("factorization helper (CHOLMOD):"));
  CHECK_THAT(r.out, Contains("peak resident memory"));
  CHECK_THAT(r.err, Contains("timed run 3 of 3"));
}

TEST_CASE("bench: --json - puts the JSON on stdout; a failing run exits 1 naming the node", "[bench]") {
  const fs::path dir = bench_dir("stdout");
  const std::string baseline = std::string(POLYHEX_SOURCE_DIR) + "/configs/baseline.json";
  const std::string cube = std::string(POLYHEX_SOURCE_DIR) + "/tests/fixtures/io/cube.off";
  CliRun r = bench(baseline + " --input " + cube +
                       " --set tets.edge_length=0.2 --set quality.samples=1000"
                       " --threads 1 --repeat 2 --warmup 0 --json -",
                   dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const json b = json::parse(r.out);  // nothing but the JSON on stdout
  CHECK(b["repeat"] == 2);
  CHECK(b["warmup"] == 0);
  check_stats(b["total"], 2);
  CHECK_THAT(r.err, Contains("median s"));  // the table went to stderr
  CHECK_FALSE(b["nodes"][2].contains("solver"));

  CliRun bad =
      bench(baseline + " --set surface.path=/nonexistent/part.off --repeat 2 --json " + (dir / "bench.json").string(),
            bench_dir("failing"));
  CHECK(bad.code == 1);
  CHECK_THAT(bad.err, Contains("warm-up run 1 failed: node `surface` (`read_surface/default`): /nonexistent/part.off"));
  CHECK_FALSE(fs::exists(dir / "bench.json"));
}
