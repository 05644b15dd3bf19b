// Config errors on the real nodes (test_pipeline.cpp covers the same kinds on test-only nodes):
// unknown variant, out-of-range and mistyped params of the meshing stages, bad --set values,
// malformed JSON with its position, and a config whose ${input} is missing.
#include "graph/config.h"
#include "graph/pipeline.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <unistd.h>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

Pipeline build_real(const std::string& text) { return Pipeline::build(parse_config(json::parse(text), "cfg.json")); }

/// The default config's first two nodes with `tets` params replaced.
std::string surface_and_tets(const std::string& tets_params) {
  return R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"shape:box"}},
                      {"id":"tets","type":"tetrahedralize/tetgen","params":)" +
         tets_params + R"(,"inputs":{"surface":"surface"}}]})";
}

}  // namespace

TEST_CASE("config errors on the real nodes name the node, the param and the valid range", "[graph][badinput]") {
  SECTION("unknown variant of a known stage") {
    REQUIRE_THROWS_AS(build_real(R"({"nodes":[{"id":"t","type":"tetrahedralize/delaunay"}]})"), ConfigError);
    REQUIRE_THROWS_WITH(build_real(R"({"nodes":[{"id":"t","type":"tetrahedralize/delaunay"}]})"),
                        Contains("node `t` (`tetrahedralize/delaunay`): unknown node type `tetrahedralize/delaunay`") &&
                            Contains("tetrahedralize/tetgen"));
  }
  SECTION("negative and zero edge length") {
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"edge_length":-0.1})")),
                        Contains("node `tets`") && Contains("param `edge_length` = -0.1 is out of range [0.002, 0.5]"));
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"edge_length":0})")),
                        Contains("param `edge_length` = 0 is out of range"));
  }
  SECTION("zero iterations") {
    REQUIRE_THROWS_WITH(build_real(R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"shape:box"}},
        {"id":"tets","type":"tetrahedralize/tetgen","inputs":["surface"]},
        {"id":"rotate","type":"rotation_deform/quaternion_laplace","params":{"iterations":0},"inputs":["tets"]}]})"),
                        Contains("node `rotate`") && Contains("param `iterations` = 0 is out of range [1.0, 50.0]"));
  }
  SECTION("mistyped params") {
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"edge_length":"0.02"})")),
                        Contains("node `tets`") && Contains("param `edge_length` must be a number, got \"0.02\""));
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"max_tets":1e6})")),
                        Contains("param `max_tets` must be an integer"));
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"refine_surface":"yes"})")),
                        Contains("param `refine_surface` must be true or false"));
    REQUIRE_THROWS_WITH(build_real(surface_and_tets(R"({"edgelength":0.02})")),
                        Contains("unknown param `edgelength`") && Contains("edge_length"));
  }
  SECTION("a writer's format out of its choices") {
    REQUIRE_THROWS_WITH(
        build_real(R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"shape:box"}},
                      {"id":"tets","type":"tetrahedralize/tetgen","inputs":["surface"]},
                      {"id":"w","type":"write_tetmesh","params":{"format":"stl"},"inputs":["tets"]}]})"),
        Contains("node `w`") && Contains("param `format` = \"stl\" is not one of: auto, vtk, vtk_binary, mesh, msh"));
  }
  SECTION("boundary_groups: an unknown param, an angle out of range, a surface where the map is expected") {
    const std::string head = R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"shape:box"}},
                      {"id":"tets","type":"tetrahedralize/tetgen","inputs":["surface"]},
                      {"id":"hex","type":"hex_from_tets","inputs":["tets"]},)";
    REQUIRE_THROWS_WITH(build_real(head + R"({"id":"g","type":"boundary_groups","params":{"chart":false},
                                               "inputs":{"hexes":"hex"}}]})"),
                        Contains("node `g`") && Contains("unknown param `chart`") && Contains("charts"));
    REQUIRE_THROWS_WITH(build_real(head + R"({"id":"g","type":"boundary_groups","params":{"feature_angle":180},
                                               "inputs":{"hexes":"hex"}}]})"),
                        Contains("node `g`") && Contains("param `feature_angle` = 180 is out of range"));
    REQUIRE_THROWS_WITH(build_real(head + R"({"id":"g","type":"boundary_groups",
                                               "inputs":{"hexes":"hex","map":"surface"}}]})"),
                        Contains("node `g`") && Contains("expects PolyCubeMap"));
  }
  SECTION("a surface where a tet mesh is expected") {
    REQUIRE_THROWS_WITH(build_real(R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"shape:box"}},
                      {"id":"rotate","type":"rotation_deform/quaternion_laplace","inputs":["surface"]}]})"),
                        Contains("node `rotate`") && Contains("expects TetMesh but node `surface`") &&
                            Contains("produces SurfaceMesh"));
  }
}

TEST_CASE("config: --set overrides with bad values and malformed config files", "[graph][badinput]") {
  const auto dir = std::filesystem::temp_directory_path() / ("polyhex_cfgerr_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  json j = json::parse(surface_and_tets(R"({"edge_length":0.05})"));
  SECTION("a number param set to a word") {
    json k = j;
    apply_override(k, "tets.edge_length=fine");
    REQUIRE_THROWS_WITH(Pipeline::build(parse_config(k, "cfg.json")),
                        Contains("node `tets`") && Contains("param `edge_length` must be a number, got \"fine\""));
  }
  SECTION("an override without a param name or value") {
    json k = j;
    REQUIRE_THROWS_AS(apply_override(k, "tets=0.1"), ConfigError);
    REQUIRE_THROWS_AS(apply_override(k, "tets.edge_length"), ConfigError);
  }
  SECTION("malformed JSON names the file and the position") {
    std::ofstream(dir / "trailing.json") << "{\"nodes\": [\n  {\"id\": \"a\", \"type\": \"read_surface\"},\n]}\n";
    REQUIRE_THROWS_AS(load_config_json(dir / "trailing.json", {}), ConfigError);
    REQUIRE_THROWS_WITH(load_config_json(dir / "trailing.json", {}),
                        Contains("trailing.json: not valid JSON") && Contains("line 3"));
    std::ofstream(dir / "empty.json") << "";
    REQUIRE_THROWS_WITH(load_config_json(dir / "empty.json", {}), Contains("empty.json: not valid JSON"));
    std::ofstream(dir / "array.json") << "[1, 2]";
    REQUIRE_THROWS_AS(Pipeline::build(parse_config(load_config_json(dir / "array.json", {}), "array.json")),
                      ConfigError);
  }
  SECTION("${input} without a default and no --input") {
    std::ofstream(dir / "needs_input.json")
        << R"({"nodes":[{"id":"surface","type":"read_surface","params":{"path":"${input}"}}]})";
    REQUIRE_THROWS_AS(load_config_json(dir / "needs_input.json", {}), ConfigError);
    REQUIRE_THROWS_WITH(load_config_json(dir / "needs_input.json", {}), Contains("input"));
  }
  std::filesystem::remove_all(dir);
}
