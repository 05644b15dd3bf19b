// Determinism: the same input and config give byte-identical meshes and identical figures for 1, 2
// and 8 threads and across repeated runs (issue 8). Also: the BLAS under CHOLMOD runs on one thread, and
// the mesh does not depend on the BLAS kernels the environment names.
#include "runtime/factorization.h"
#include "tests/helpers/cli.h"
#include "tests/helpers/report.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include <dlfcn.h>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::read_text;
using polyhex::test::run_command;

namespace {

/// Wall-clock figures, which legitimately differ between runs.
bool timing_key(const std::string& k) { return k.find("seconds") != std::string::npos || k == "factor_solve_fraction"; }

/// Every difference between two reports' node metrics (timings left out), as "node.key: a != b".
std::vector<std::string> metric_differences(const json& a, const json& b) {
  std::vector<std::string> out;
  for (auto it = a["nodes"].begin(); it != a["nodes"].end(); ++it) {
    const json& ma = it.value()["metrics"];
    const json& mb = b["nodes"][it.key()]["metrics"];
    for (auto m = ma.begin(); m != ma.end(); ++m)
      if (!timing_key(m.key()) && (!mb.contains(m.key()) || mb[m.key()] != m.value()))
        out.push_back(it.key() + "." + m.key() + ": " + m.value().dump() +
                      " != " + (mb.contains(m.key()) ? mb[m.key()].dump() : std::string("(missing)")));
    if (mb.size() != ma.size()) out.push_back(it.key() + ": different metric keys");
  }
  return out;
}

}  // namespace

TEST_CASE("determinism: default config, 1 / 2 / 8 threads and a repeated run give identical bytes and figures",
          "[robust][cli]") {
  const fs::path root = polyhex::test::fresh_dir("robust_det");
  const std::string bin = POLYHEX_BINARY;
  // a coarse built-in shape with curved and sharp features, so every stage has work to do
  CliRun s =
      run_command(bin + " shapes fandisk_like --resolution 16 --out " + (root / "fandisk.obj").string() + " 2>&1");
  INFO(s.out);
  REQUIRE(s.code == 0);

  struct Run {
    int threads;
    std::string mesh;
    json report;
  };
  std::vector<Run> runs;
  for (int threads : {1, 2, 8, 8}) {
    // each run in its own folder, with the same relative output path: the reports name the same file,
    // and no run can find another's artefact cache
    const fs::path dir = root / ("run" + std::to_string(runs.size()));
    fs::create_directories(dir);
    CliRun r = run_command(
        "cd " + dir.string() + " && " + bin + " run " + POLYHEX_SOURCE_DIR + "/configs/default.json" +
        " --input ../fandisk.obj --out out --threads " + std::to_string(threads) +
        " --set tets.edge_length=0.06 --set segment.hex_edge_length=0.06 --set polycube.edge_length=0.06 2>&1");
    INFO("threads " << threads << ": " << r.out);
    REQUIRE(r.code == 0);
    runs.push_back({threads, read_text(dir / "out" / "hex.vtk"), json::parse(read_text(dir / "out" / "report.json"))});
  }
  const Run& ref = runs.front();
  REQUIRE(ref.mesh.size() > 10000);
  const json& q = ref.report["nodes"]["quality"]["metrics"];
  REQUIRE(q["hexes"].get<long>() > 300);
  CHECK(q["inverted"] == 0);
  CHECK(polyhex::test::kept_node(ref.report, "optimize")["metrics"]["time_budget_hit"] == false);
  for (size_t i = 1; i < runs.size(); ++i) {
    INFO("run " << i << " with " << runs[i].threads << " threads against 1 thread");
    CHECK(runs[i].mesh == ref.mesh);
    CHECK(metric_differences(ref.report, runs[i].report) == std::vector<std::string>{});
    for (auto& n : runs[i].report["nodes"]) CHECK(n.value("cache_hit", false) == false);
  }
  fs::remove_all(root);
}

TEST_CASE("determinism: OpenBLAS under CHOLMOD runs on one thread once a factorization exists", "[robust]") {
  Eigen::SparseMatrix<double> A(3, 3);
  A.insert(0, 0) = 4;
  A.insert(1, 1) = 5;
  A.insert(2, 2) = 6;
  A.insert(1, 0) = 1;
  polyhex::CholmodFactorization f(A);
  REQUIRE(f.factored());
  using GetThreads = int (*)();
  auto get = reinterpret_cast<GetThreads>(::dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (!get) {
    WARN("the BLAS is not OpenBLAS: nothing to check");
    SUCCEED();
    return;
  }
  CHECK(get() == 1);
}

TEST_CASE("determinism: the mesh does not depend on the OpenBLAS kernels the environment names", "[robust][cli]") {
  // OpenBLAS's Haswell and SkylakeX kernels give meshes that differ in their last bits (this shape's did
  // before the kernels were pinned): with the CPU's choice or with the environment's, the same file.
  if (!polyhex::blas_kernels_for_this_cpu()) {
    WARN("this CPU runs neither of the two kernel sets: nothing to check");
    return;
  }
  const fs::path root = polyhex::test::fresh_dir("robust_blas_kernels");
  std::vector<std::string> mesh;
  for (const char* env : {"env -u OPENBLAS_CORETYPE", "env OPENBLAS_CORETYPE=Haswell"}) {
    const fs::path out = root / std::to_string(mesh.size());
    const CliRun r = run_command(std::string(env) + " " + POLYHEX_BINARY + " run " + POLYHEX_SOURCE_DIR +
                                 "/configs/default.json -i shape:fandisk_like --hex-edge 0.04 --threads 2 --no-cache"
                                 " --out " +
                                 out.string() + " 2>&1");
    INFO(env << "\n" << r.out);
    REQUIRE(r.code == 0);
    mesh.push_back(read_text(out / "hex.vtk"));
  }
  CHECK(mesh[0] == mesh[1]);
  fs::remove_all(root);
}
