// The read_hex node (configs/optimize_only.json reruns the optimization on a saved mesh).
#include "graph/node.h"
#include "nodes/formats/hexmesh_io.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>

#include <filesystem>

using namespace polyhex;

TEST_CASE("read_hex reads a saved hex mesh exactly and names a missing file", "[quality-opt]") {
  const NodeSpec* spec = Registry::instance().find("read_hex");
  REQUIRE(spec != nullptr);
  CHECK(spec->inputs.empty());
  HexMesh g = test::grid_hex_mesh(2, 3, 1, 0.1);
  g.V(4, 0) += 1.0 / 3.0;  // not a short decimal: the round trip must be exact
  const auto dir = std::filesystem::temp_directory_path() / "polyhex_read_hex_test";
  std::filesystem::create_directories(dir);
  const auto file = dir / "g.vtk";
  write_hexmesh(g, file, "vtk");
  Inputs in;
  NodeContext ctx;
  ctx.id = "hexes";
  Artefact a = spec->run(spec->check_params(json{{"path", file.string()}}, "hexes"), in, ctx);
  const HexMesh& m = *a.as<HexMesh>();
  CHECK(m.H == g.H);
  CHECK(m.V == g.V);
  CHECK(ctx.metrics["hexes"].get<int>() == 6);
  REQUIRE(spec->input_files);
  CHECK(spec->input_files(json{{"path", file.string()}}) == std::vector<std::filesystem::path>{file});
  NodeContext ctx2;
  ctx2.id = "hexes";
  REQUIRE_THROWS_WITH(spec->run(spec->check_params(json{{"path", (dir / "none.vtk").string()}}, "hexes"), in, ctx2),
                      Catch::Contains("none.vtk"));
  REQUIRE_THROWS_WITH(spec->run(spec->check_params(json{{"path", ""}}, "hexes"), in, ctx2), Catch::Contains("path"));
  std::filesystem::remove_all(dir);
}
