// The hex writers with boundary groups (hexmesh_io.h, solver_formats.h): face numbering per format, what
// each format holds, atomic writes and refused input. Read-back by real clients: test_hex_clients.cpp.
#include "nodes/artefacts/boundary_groups.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/solver_formats.h"
#include "nodes/formats/tetmesh_io.h"
#include "runtime/errors.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <thread>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Matchers::Contains;
using polyhex::test::read_text;
namespace fs = std::filesystem;

namespace {

bool leftovers(const fs::path& dir) {
  for (auto& e : fs::directory_iterator(dir))
    if (e.path().string().find(".tmp.") != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("hex writers: Exodus side and Abaqus face numbers of our local faces", "[io]") {
  // ours (hex_topology::kFaces): 0 bottom 0-3-2-1, 1 top 4-5-6-7, 2 0-1-5-4, 3 1-2-6-5, 4 2-3-7-6, 5 3-0-4-7
  CHECK(exodus_hex_sides() == std::array<int, 6>{5, 6, 1, 2, 3, 4});
  CHECK(abaqus_hex_faces() == std::array<int, 6>{1, 2, 3, 4, 5, 6});
}

TEST_CASE("hex writers: every format holds the groups, written atomically", "[io]") {
  TempDir dir;
  const HexMesh m = hex_grid_with_side_groups(2);
  REQUIRE(boundary_groups_problem(m).empty());
  for (const char* name : {"g.vtk", "g.mesh", "g.msh", "g.e", "g.exo", "g.inp"}) write_hexmesh(m, dir / name);
  CHECK_FALSE(leftovers(dir.path));
  for (const char* name : {"g.vtk", "g.mesh", "g.msh", "g.e", "g.exo", "g.inp"}) CHECK(fs::file_size(dir / name) > 0);
  // Exodus II is netCDF: classic or 64-bit-offset files start with "CDF"
  CHECK(read_text(dir / "g.e").substr(0, 3) == "CDF");

  const std::string inp = read_text(dir / "g.inp");
  CHECK_THAT(inp, Contains("*ELEMENT, TYPE=C3D8, ELSET=volume\n1, 1, 2, 5, 4, 10, 11, 14, 13\n"));
  CHECK_THAT(inp, Contains("*SURFACE, NAME=side_5, TYPE=ELEMENT\n1, S6\n3, S6\n5, S6\n7, S6\n"));  // x = 0
  CHECK_THAT(inp, Contains("*SURFACE, NAME=side_0, TYPE=ELEMENT\n1, S1\n2, S1\n3, S1\n4, S1\n"));  // z = 0: bottom
  CHECK_THAT(inp, Contains("*NSET, NSET=side_0\n1, 2, 3, 4, 5, 6, 7, 8, 9\n"));
  const std::string msh = read_text(dir / "g.msh");
  CHECK_THAT(msh, Contains("$PhysicalNames\n8\n3 1 \"volume\"\n2 1 \"boundary\"\n2 2 \"side_0\"\n"));
  // 6 surface entities (each side's faces are in `boundary` and one side group) and the volume
  CHECK_THAT(msh, Contains("$Entities\n0 0 6 1\n"));
  CHECK_THAT(msh, Contains("$Elements\n7 32 1 32\n3 1 5 8\n"));
  const std::string vtk = read_text(dir / "g.vtk");
  CHECK_THAT(vtk, Contains("CELLS 32 192\n") && Contains("SCALARS side int 1") && Contains("SCALARS boundary int 1"));
  const std::string medit = read_text(dir / "g.mesh");
  // one reference per face, its side id: hex 1 has its bottom (side_0) and its y = 0 face (side_2) first
  CHECK_THAT(medit, Contains("Quadrilaterals\n24\n1 4 5 2 0\n1 2 11 10 2\n"));

  // our own readers still read the hexes (and skip the faces)
  for (const char* name : {"g.vtk", "g.mesh", "g.msh"}) {
    HexReadReport r;
    const HexMesh back = read_hexmesh(dir / name, &r);
    CHECK(back.H == m.H);
  }
}

TEST_CASE("hex writers: bad groups, unknown formats and failed writes leave no file", "[io]") {
  TempDir dir;
  HexMesh m = hex_grid_with_side_groups(2);
  m.groups[0].faces.push_back({8, 0});  // hex 8 does not exist
  for (const char* name : {"b.vtk", "b.mesh", "b.msh", "b.e", "b.inp"}) {
    CHECK_THROWS_WITH(write_hexmesh(m, dir / name), Contains(name) && Contains("`boundary`") &&
                                                        Contains("out of range") && Contains("no file written"));
    CHECK_FALSE(fs::exists(dir / name));
  }
  m = hex_grid_with_side_groups(2);
  m.groups[2].name = "1st";
  CHECK_THROWS_WITH(write_hexmesh(m, dir / "b.e"), Contains("the name must be a letter"));
  m = hex_grid_with_side_groups(2);
  CHECK_THROWS_WITH(write_hexmesh(m, dir / "b.stl"), Contains(".e, .exo or .inp"));
  CHECK_THROWS_AS(write_hexmesh(m, dir / "b.vtk", "exodus2"), ConfigError);
  CHECK_THROWS_AS(write_tetmesh(two_tets(), dir / "t.e"), IOError);  // Exodus and Abaqus are for hexes
  CHECK_THROWS_AS(write_tetmesh(two_tets(), dir / "t.vtk", "exodus"), ConfigError);
  // the Exodus library cannot create a file in a missing folder: an error naming the file, nothing left
  CHECK_THROWS_WITH(write_hexmesh(m, dir / "missing" / "b.e"),
                    Contains("b.e") && Contains("Exodus II library: ex_create"));
  CHECK_FALSE(leftovers(dir.path));
  // an existing file is replaced whole, or kept when the write fails
  write_hexmesh(m, dir / "keep.e");
  const std::string before = read_text(dir / "keep.e");
  HexMesh bad = m;
  bad.groups[0].faces = {{0, 7}};
  CHECK_THROWS(write_hexmesh(bad, dir / "keep.e"));
  CHECK(read_text(dir / "keep.e") == before);
}

TEST_CASE("hex writers: Exodus files written from several threads at once are whole", "[io]") {
  // two write_hex nodes of one graph may run at once; the Exodus library is not thread-safe
  TempDir dir;
  const HexMesh m = hex_grid_with_side_groups(3);
  write_hexmesh(m, dir / "ref.e");
  const std::string ref = read_text(dir / "ref.e");
  REQUIRE(ref.size() > 1000);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int k = 0; k < 5; ++k) write_hexmesh(m, dir / ("t" + std::to_string(t) + "_" + std::to_string(k) + ".e"));
    });
  for (auto& t : threads) t.join();
  for (int t = 0; t < 4; ++t)
    for (int k = 0; k < 5; ++k)
      CHECK(read_text(dir / ("t" + std::to_string(t) + "_" + std::to_string(k) + ".e")) == ref);
  CHECK_FALSE(leftovers(dir.path));
}
