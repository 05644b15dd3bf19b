#include "graph/node.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Contains;

namespace {
Artefact run_node(const std::string& type, const json& params, Inputs in, NodeContext& ctx) {
  const NodeSpec* spec = Registry::instance().find(type);
  REQUIRE(spec);
  ctx.type = spec->type;
  return spec->run(spec->check_params(params, ctx.id), in, ctx);
}
}  // namespace

TEST_CASE("read_surface node: metrics and warnings", "[io]") {
  NodeContext ctx;
  ctx.id = "surface";
  Artefact a = run_node("read_surface", {{"path", fixture("tetra_ascii.stl").string()}}, {}, ctx);
  auto m = a.as<SurfaceMesh>();
  CHECK(m->F.rows() == 4);
  CHECK(ctx.metrics["vertices"] == 4);
  CHECK(ctx.metrics["faces"] == 4);
  CHECK(ctx.metrics["welded"] == 8);
  CHECK(ctx.metrics["flipped"] == 0);
  CHECK(ctx.metrics["genus"] == 0);
  CHECK(ctx.metrics["components"] == 1);
  REQUIRE(ctx.warnings.size() == 1);
  CHECK_THAT(ctx.warnings[0], Contains("welded 8 duplicate vertices"));
  NodeContext empty;
  REQUIRE_THROWS_WITH(run_node("read_surface", json::object(), {}, empty), Contains("param `path` is empty"));
  const NodeSpec* spec = Registry::instance().find("read_surface");
  REQUIRE_THROWS_AS(spec->check_params({{"file", "x"}}, "surface"), ConfigError);
  CHECK(spec->output == "SurfaceMesh");
  CHECK(spec->inputs.empty());
}

TEST_CASE("read_tetmesh node: metrics", "[io]") {
  NodeContext ctx;
  ctx.id = "tets";
  Artefact a = run_node("read_tetmesh", {{"path", fixture("two_tets.mesh").string()}}, {}, ctx);
  CHECK(a.as<TetMesh>()->T.rows() == 2);
  CHECK(ctx.metrics["vertices"] == 5);
  CHECK(ctx.metrics["tets"] == 2);
  CHECK(ctx.metrics["reoriented"] == 1);
  CHECK(ctx.warnings.size() == 1);
}

TEST_CASE("write_hex and write_tetmesh nodes write under the output folder", "[io]") {
  TempDir dir;
  NodeContext ctx;
  ctx.id = "write";
  ctx.out_dir = dir.path;
  HexMesh h = hex_grid(2);
  Inputs in;
  in.items.push_back(make_artefact(h));
  Artefact out = run_node("write_hex", json::object(), in, ctx);
  CHECK(!out);
  CHECK(out.type.empty());
  REQUIRE(std::filesystem::exists(dir / "hex.vtk"));
  CHECK(ctx.metrics["path"] == (dir / "hex.vtk").string());
  CHECK(ctx.metrics["bytes"] == std::filesystem::file_size(dir / "hex.vtk"));
  CHECK(read_hexmesh(dir / "hex.vtk").H == h.H);

  NodeContext c2;
  c2.out_dir = dir.path;
  run_node("write_hex", {{"path", "sub/h.data"}, {"format", "mesh"}}, in, c2);
  CHECK(c2.metrics["path"] == (dir / "sub" / "h.data").string());
  std::filesystem::rename(dir / "sub" / "h.data", dir / "sub" / "h.mesh");
  CHECK(read_hexmesh(dir / "sub" / "h.mesh").H.rows() == 8);

  const NodeSpec* spec = Registry::instance().find("write_hex");
  REQUIRE_THROWS_WITH(spec->check_params({{"format", "stl"}}, "write"), Contains("is not one of: auto, vtk"));
  CHECK(spec->output.empty());
  REQUIRE(spec->inputs.size() == 1);
  CHECK(spec->inputs[0].artefact_type == "HexMesh");

  NodeContext c3;
  c3.out_dir = dir.path;
  Inputs tin;
  tin.items.push_back(make_artefact(two_tets()));
  run_node("write_tetmesh", json::object(), tin, c3);
  CHECK(read_tetmesh(dir / "tets.vtk").T == two_tets().T);
  CHECK(c3.metrics["bytes"].get<long>() > 100);
}

TEST_CASE("savers for --save-all are registered for the three mesh types", "[io]") {
  TempDir dir;
  auto [hext, hsave] = Registry::instance().saver("HexMesh");
  auto [text, tsave] = Registry::instance().saver("TetMesh");
  auto [sext, ssave] = Registry::instance().saver("SurfaceMesh");
  REQUIRE(hsave);
  REQUIRE(tsave);
  REQUIRE(ssave);
  CHECK(hext == ".vtk");
  CHECK(text == ".vtk");
  CHECK(sext == ".obj");
  hsave(make_artefact(hex_grid(1)), dir / "h.vtk");
  CHECK(read_hexmesh(dir / "h.vtk").H.rows() == 1);
  tsave(make_artefact(two_tets()), dir / "t.vtk");
  CHECK(read_tetmesh(dir / "t.vtk").T.rows() == 2);
  ssave(make_artefact(read_surface(fixture("tetra.obj"))), dir / "s.obj");
  CHECK(read_surface(dir / "s.obj").F.rows() == 4);
}
