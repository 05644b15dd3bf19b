// The artefact cache through the polyhex binary: default location, --cache/--no-cache, two concurrent
// processes on one cache, and `polyhex cache stats|clear|prune`.
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::finish_command;
using polyhex::test::run_polyhex;
using polyhex::test::start_polyhex;

namespace {

// A small baseline pipeline on a built-in box: shapes -> TetGen -> split -> VTK.
fs::path write_config(const fs::path& dir) {
  const fs::path p = dir / "box.json";
  std::ofstream(p) << R"({"nodes": [
    {"id": "surface", "type": "shapes", "params": {"name": "box", "resolution": 10}},
    {"id": "tets", "type": "tetrahedralize/tetgen", "params": {"edge_length": 0.1}, "inputs": {"surface": "surface"}},
    {"id": "hex", "type": "hex_from_tets/split", "inputs": {"tets": "tets"}},
    {"id": "write", "type": "write_hex", "params": {"path": "hex.vtk"}, "inputs": {"mesh": "hex"}}]})";
  return p;
}

json report(const fs::path& out) {
  std::ifstream in(out / "report.json");
  return json::parse(in);
}

json stats(const fs::path& cache) {
  CliRun r = run_polyhex("cache stats --json --cache " + cache.string());
  INFO(r.out);
  REQUIRE(r.code == 0);
  return json::parse(r.out);
}

}  // namespace

TEST_CASE("cache cli: two concurrent runs on one cache both succeed with identical outputs", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_cli_concurrent");
  const fs::path cfg = write_config(dir);
  const fs::path cache = dir / "shared-cache";
  const std::string common = "run " + cfg.string() + " --threads 1 --cache " + cache.string() + " --out ";
  FILE* a = start_polyhex(common + (dir / "a").string());
  FILE* b = start_polyhex(common + (dir / "b").string());
  CliRun ra = finish_command(a), rb = finish_command(b);
  INFO(ra.out);
  INFO(rb.out);
  REQUIRE(ra.code == 0);
  REQUIRE(rb.code == 0);
  const std::string mesh = polyhex::test::read_text(dir / "a" / "hex.vtk");
  CHECK(mesh.size() > 1000);
  CHECK(polyhex::test::read_text(dir / "b" / "hex.vtk") == mesh);
  json ja = report(dir / "a"), jb = report(dir / "b");
  for (auto id : {"surface", "tets", "hex"}) {
    INFO(id);
    json ma = ja["nodes"][id]["metrics"], mb = jb["nodes"][id]["metrics"];
    ma.erase("seconds");
    mb.erase("seconds");
    CHECK(ma == mb);
    CHECK(jb["nodes"][id]["warnings"].empty());  // no store failed, no entry was seen half-written
    CHECK(ja["nodes"][id]["warnings"].empty());
  }
  CHECK(ja["nodes"]["write"]["warnings"].empty());
  CHECK(jb["nodes"]["write"]["warnings"].empty());
  json s = stats(cache);
  CHECK(s["entries"] == 3);  // surface, tets, hex; the sink write is not cached
  CHECK(s["temp_files"] == 0);
  CHECK(s["by_type"]["tetrahedralize/tetgen"]["entries"] == 1);

  // a third run loads all three and writes the same mesh
  CliRun rc = run_polyhex("-v " + common + (dir / "c").string());
  REQUIRE(rc.code == 0);
  CHECK_THAT(rc.out, Contains("loaded from cache"));
  json jc = report(dir / "c");
  for (auto id : {"surface", "tets", "hex"}) CHECK(jc["nodes"][id]["cache_hit"] == true);
  CHECK(jc["nodes"]["write"]["cache_hit"] == false);
  CHECK(jc["nodes"]["tets"]["metrics"]["tets"] == ja["nodes"]["tets"]["metrics"]["tets"]);
  CHECK(polyhex::test::read_text(dir / "c" / "hex.vtk") == mesh);
  fs::remove_all(dir);
}

TEST_CASE("cache cli: default folder beside the output, --no-cache, and stats/prune/clear", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_cli_commands");
  const fs::path cfg = write_config(dir);
  const fs::path cache = dir / ".polyhex-cache";

  CliRun off = run_polyhex("run " + cfg.string() + " --no-cache --out " + (dir / "off").string());
  REQUIRE(off.code == 0);
  CHECK_FALSE(fs::exists(cache));
  CHECK(report(dir / "off")["nodes"]["tets"]["cache_hit"] == false);

  CliRun both =
      run_polyhex("run " + cfg.string() + " --no-cache --cache " + cache.string() + " --out " + (dir / "x").string());
  CHECK(both.code == 2);
  CHECK_THAT(both.out, Contains("--no-cache") && Contains("--cache"));

  REQUIRE(run_polyhex("run " + cfg.string() + " --out " + (dir / "runs" / "one").string()).code == 0);
  CHECK_FALSE(fs::exists(cache));  // beside the output folder: dir/runs/.polyhex-cache
  const fs::path beside = dir / "runs" / ".polyhex-cache";
  json s = stats(beside);
  REQUIRE(s["entries"] == 3);
  CHECK(s["bytes"].get<double>() > 1000);
  CHECK(s["dir"] == beside.string());
  CliRun second = run_polyhex("run " + cfg.string() + " --out " + (dir / "runs" / "two").string());
  REQUIRE(second.code == 0);
  CHECK(report(dir / "runs" / "two")["nodes"]["hex"]["cache_hit"] == true);

  CliRun text = run_polyhex("cache stats --cache " + beside.string());
  CHECK(text.code == 0);
  CHECK_THAT(text.out, Contains("3 entries") && Contains("hex_from_tets/split"));

  CliRun bad = run_polyhex("cache prune --max-size lots --cache " + beside.string());
  CHECK(bad.code == 2);
  CHECK_THAT(bad.out, Contains("size `lots`"));
  CHECK(run_polyhex("cache prune --cache " + beside.string()).code == 2);  // --max-size is required

  // prune to the size of all entries but the biggest (the hexes, the least recently used tie is broken by name)
  const auto total = s["bytes"].get<std::uintmax_t>();
  CliRun keep_all = run_polyhex("cache prune --max-size " + std::to_string(total) + " --cache " + beside.string());
  CHECK(keep_all.code == 0);
  CHECK_THAT(keep_all.out, Contains("removed 0 least recently used entries"));
  CHECK(stats(beside)["entries"] == 3);
  CliRun prune = run_polyhex("cache prune --max-size 1K --cache " + beside.string());
  CHECK(prune.code == 0);
  CHECK(stats(beside)["bytes"].get<double>() <= 1024);

  REQUIRE(run_polyhex("run " + cfg.string() + " --out " + (dir / "runs" / "three").string()).code == 0);
  CHECK(stats(beside)["entries"] == 3);
  CliRun clear = run_polyhex("cache clear --cache " + beside.string());
  CHECK(clear.code == 0);
  CHECK_THAT(clear.out, Contains("removed 3 entries"));
  CHECK(stats(beside)["entries"] == 0);
  fs::remove_all(dir);
}
