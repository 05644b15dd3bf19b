// The default config on a turned part: the same sizes as the part in its own frame, the part's frame
// found, and a mesh on the turned input's surface (not on the part where it was before turning).
#include "nodes/algorithms/shapes.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"
#include "tests/helpers/cli.h"
#include "tests/helpers/report.h"
#include "tests/helpers/rotations.h"

#include <catch2/catch.hpp>

#include <cmath>

using json = nlohmann::json;
namespace fs = std::filesystem;
using polyhex::test::kept_node;

namespace {

json run_default(const fs::path& input, const fs::path& out, const std::string& more = "") {
  const auto r = polyhex::test::run_polyhex("run " + std::string(POLYHEX_SOURCE_DIR) + "/configs/default.json -i " +
                                            input.string() + " --hex-edge 0.04 --threads 2 --no-cache --out " +
                                            out.string() + more);
  INFO(r.out);
  REQUIRE(r.code == 0);
  return json::parse(polyhex::test::read_text(out / "report.json"));
}

}  // namespace

TEST_CASE("orient: a turned L-block is meshed in its own frame, at the same size, on the turned surface",
          "[orient][cli]") {
  const fs::path dir = polyhex::test::fresh_dir("orient_turned");
  const polyhex::SurfaceMesh block = polyhex::make_shape({"l_block", 32});
  polyhex::write_surface(block, dir / "block.obj");
  polyhex::write_surface(polyhex::test::rotated(block, polyhex::test::seeded_rotation(7)), dir / "turned.obj");
  const json a = run_default(dir / "block.obj", dir / "a");
  const json b = run_default(dir / "turned.obj", dir / "b", " --save-all");
  const json& qa = a["nodes"]["quality"]["metrics"];
  const json& qb = b["nodes"]["quality"]["metrics"];
  CHECK(qa["inverted"] == 0);
  CHECK(qb["inverted"] == 0);
  // Sizes: the tet and hex edges of the turned part are those of the part.
  const double ta = a["nodes"]["tets"]["metrics"]["target_edge"], tb = b["nodes"]["tets"]["metrics"]["target_edge"];
  CHECK(std::abs(ta - tb) <= 1e-6 * ta);
  const double ha = kept_node(a, "polycube")["metrics"]["edge_length_abs"];
  const double hb = kept_node(b, "polycube")["metrics"]["edge_length_abs"];
  CHECK(std::abs(ha - hb) <= 1e-6 * ha);
  // The frame kept for the turned part is a found one, not the turned input frame; the axis-aligned part
  // runs in its input frame alone.
  CHECK(a["nodes"]["orient"]["metrics"]["branches"] == 1);
  CHECK(a["nodes"]["orient"]["metrics"]["candidates"][0]["branch"] == 1);
  const int kept = b["nodes"]["best"]["metrics"]["chosen"];
  for (const json& c : b["nodes"]["orient"]["metrics"]["candidates"])
    if (c["branch"] == kept) CHECK(c["source"] != "input");
  CHECK(std::abs(qb["hexes"].get<double>() / qa["hexes"].get<double>() - 1) <= 0.15);
  CHECK(qb["sj_min"].get<double>() >= 0.9 * qa["sj_min"].get<double>());
  // On the turned input's surface: the quality node measures against the run's input (turned.obj) ...
  CHECK(qb["hausdorff_max"].get<double>() < 0.5 * 0.04);
  // ... and the mesh is far from the part where it was before turning.
  const auto check = polyhex::test::run_polyhex("check " + (dir / "b" / "hex.vtk").string() + " --surface " +
                                                (dir / "block.obj").string() + " --json");
  const json cj = json::parse(check.out.substr(check.out.find('{')));
  CHECK(cj["hausdorff_max"].get<double>() > 0.1);
  // --save-all writes the branch's artefacts in the input's frame: its turned tets are the tets.
  const polyhex::TetMesh tets = polyhex::read_tetmesh(dir / "b" / "tets.vtk");
  const polyhex::TetMesh framed = polyhex::read_tetmesh(dir / "b" / ("frame_tets#" + std::to_string(kept) + ".vtk"));
  REQUIRE(framed.V.rows() == tets.V.rows());
  CHECK((framed.V - tets.V).cwiseAbs().maxCoeff() < 1e-6 * ta);
}

TEST_CASE("placement canonical: a turned and moved copy of a part gets the same mesh, turned and moved",
          "[orient][placement][cli]") {
  const fs::path dir = polyhex::test::fresh_dir("placement_canonical");
  const polyhex::SurfaceMesh part = polyhex::make_shape({"l_block", 32});
  const Eigen::Matrix3d R = polyhex::test::seeded_rotation(11);
  const Eigen::Vector3d t(5, -3, 2);
  const polyhex::SurfaceMesh copy = polyhex::test::moved(part, R, t);
  polyhex::write_surface(part, dir / "part.obj");
  polyhex::write_surface(copy, dir / "copy.obj");
  const std::string canonical = " --set placement.frame=canonical";
  const json a = run_default(dir / "part.obj", dir / "a", canonical);
  const json b = run_default(dir / "copy.obj", dir / "b", canonical + " --save-all");
  const json& qa = a["nodes"]["quality"]["metrics"];
  const json& qb = b["nodes"]["quality"]["metrics"];
  CHECK(qa["inverted"] == 0);
  CHECK(qb["hexes"] == qa["hexes"]);
  CHECK(std::abs(qb["sj_min"].get<double>() - qa["sj_min"].get<double>()) < 1e-12);
  CHECK(std::abs(qb["sj_avg"].get<double>() - qa["sj_avg"].get<double>()) < 1e-12);
  // the part's own axes are a minimum of the search: a found frame runs in their place, in both runs
  CHECK(a["nodes"]["orient"]["metrics"]["candidates"][0]["branch"] == 0);
  // the copy's mesh is the part's mesh moved with it, and lies on the copy's surface
  const polyhex::HexMesh ha = polyhex::read_hexmesh(dir / "a" / "hex.vtk");
  const polyhex::HexMesh hb = polyhex::read_hexmesh(dir / "b" / "hex.vtk");
  REQUIRE(ha.V.rows() == hb.V.rows());
  CHECK(ha.H == hb.H);
  const polyhex::RowMatrixX3d expected = (ha.V * R.transpose()).rowwise() + t.transpose();
  CHECK((hb.V - expected).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(qb["hausdorff_max"].get<double>() < 0.5 * 0.04);
  // --save-all writes what was built in the canonical frame in the input's frame: the placed surface is the
  // copy (within the grid), the tets fill the conditioned surface's box, a branch's tets are the tets
  const double grid = b["nodes"]["placement"]["metrics"]["grid"];
  CHECK(grid > 0);
  const polyhex::SurfaceMesh placed = polyhex::read_surface(dir / "b" / "placed.obj");
  REQUIRE(placed.V.rows() == copy.V.rows());
  CHECK((placed.V - copy.V).cwiseAbs().maxCoeff() < 2 * grid);
  const polyhex::SurfaceMesh conditioned = polyhex::read_surface(dir / "b" / "condition.obj");
  const polyhex::TetMesh tets = polyhex::read_tetmesh(dir / "b" / "tets.vtk");
  CHECK((tets.V.colwise().minCoeff() - conditioned.V.colwise().minCoeff()).cwiseAbs().maxCoeff() < 1e-9);
  CHECK((tets.V.colwise().maxCoeff() - conditioned.V.colwise().maxCoeff()).cwiseAbs().maxCoeff() < 1e-9);
  const int kept = b["nodes"]["best"]["metrics"]["chosen"];
  const polyhex::TetMesh framed = polyhex::read_tetmesh(dir / "b" / ("frame_tets#" + std::to_string(kept) + ".vtk"));
  REQUIRE(framed.V.rows() == tets.V.rows());
  CHECK((framed.V - tets.V).cwiseAbs().maxCoeff() < 1e-9);
}
