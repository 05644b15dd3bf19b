#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/tetmesh_io.h"
#include "runtime/errors.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <sstream>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Contains;

namespace {

bool has_warning(const std::vector<std::string>& warnings, const std::string& part) {
  for (auto& w : warnings)
    if (w.find(part) != std::string::npos) return true;
  return false;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("read_tetmesh: every fixture format gives the two positive tets", "[io]") {
  const TetMesh expected = two_tets();
  for (const char* name :
       {"two_tets.mesh", "two_tets.vtk", "two_tets_v22.msh", "two_tets_v41.msh", "two_tets.node", "two_tets.ele"}) {
    SECTION(name) {
      TetReadReport r;
      TetMesh m = read_tetmesh(fixture(name), &r);
      CHECK(m.V == expected.V);
      REQUIRE(m.T.rows() == 2);
      CHECK(r.vertices == 5);
      CHECK(r.tets == 2);
      for (int t = 0; t < 2; ++t) CHECK(tet_volume(m.V, m.T.row(t)) > 0);
      CHECK(tet_volume(m.V, m.T.row(0)) + tet_volume(m.V, m.T.row(1)) == Approx(0.5));
      CHECK(m.source == fixture(name).string());
    }
  }
}

TEST_CASE("read_tetmesh: inverted tets are re-oriented, other cells ignored, with warnings", "[io]") {
  TetReadReport r;
  TetMesh m = read_tetmesh(fixture("two_tets.mesh"), &r);
  CHECK(r.reoriented == 1);
  CHECK(has_warning(r.warnings, "re-oriented 1 inverted tets"));
  CHECK(m.T.row(1) == Eigen::RowVector4i(1, 3, 4, 2));  // stored 1 3 2 4 (0-based): vertices 2 and 3 swapped

  TetReadReport v;
  read_tetmesh(fixture("two_tets.vtk"), &v);
  CHECK(v.reoriented == 0);
  CHECK(has_warning(v.warnings, "ignored 1 cell of VTK type 5 (only type 10 is read)"));
  TetReadReport g;
  read_tetmesh(fixture("two_tets_v41.msh"), &g);
  CHECK(has_warning(g.warnings, "ignored 1 element of Gmsh type 2"));
}

TEST_CASE("write_tetmesh / read_tetmesh round trip in every format", "[io]") {
  TempDir dir;
  TetMesh m = tet_grid(3);
  REQUIRE(m.T.rows() == 162);
  const std::vector<std::pair<std::string, std::string>> files = {
      {"a.vtk", "auto"}, {"b.vtk", "vtk_binary"}, {"c.mesh", "auto"}, {"d.msh", "auto"}, {"e.vtk", "vtk"}};
  for (auto& [name, format] : files) {
    SECTION(name + " " + format) {
      write_tetmesh(m, dir / name, format);
      TetReadReport r;
      TetMesh back = read_tetmesh(dir / name, &r);
      CHECK(back.V == m.V);
      CHECK(back.T == m.T);
      CHECK(r.warnings.empty());
    }
  }
  SECTION("VTK header and classic CELLS lines") {
    write_tetmesh(m, dir / "h.vtk");
    std::string text = slurp(dir / "h.vtk");
    CHECK(text.rfind("# vtk DataFile Version 2.0\n", 0) == 0);
    CHECK_THAT(text, Contains("\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 64 double\n"));
    CHECK_THAT(text, Contains("\nCELLS 162 810\n4 0 1 5 21\n"));
    CHECK_THAT(text, Contains("\nCELL_TYPES 162\n10\n"));
  }
  SECTION("per-tet arrays in ASCII and binary VTK") {
    CellData cd;
    cd.reals.push_back({"quality", std::vector<double>(162, 0.25)});
    cd.ints.push_back({"region", std::vector<int>(162, 7)});
    write_tetmesh(m, dir / "q.vtk", "vtk", cd);
    std::string text = slurp(dir / "q.vtk");
    CHECK_THAT(text, Contains("CELL_DATA 162\nSCALARS region int 1\nLOOKUP_TABLE default\n7\n"));
    CHECK_THAT(text, Contains("SCALARS quality double 1\nLOOKUP_TABLE default\n0.25\n"));
    write_tetmesh(m, dir / "qb.vtk", "vtk_binary", cd);
    std::string bin = slurp(dir / "qb.vtk");
    const std::string key = "SCALARS quality double 1\nLOOKUP_TABLE default\n";
    auto at = bin.find(key);
    REQUIRE(at != std::string::npos);
    // 0.25 big-endian: 3f d0 00 00 00 00 00 00
    CHECK(uint8_t(bin[at + key.size()]) == 0x3f);
    CHECK(uint8_t(bin[at + key.size() + 1]) == 0xd0);
    CHECK(read_tetmesh(dir / "qb.vtk").T == m.T);
  }
  SECTION("Medit and Gmsh files as written") {
    write_tetmesh(m, dir / "x.mesh");
    CHECK_THAT(slurp(dir / "x.mesh"), Contains("MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n64\n0 0 0 0\n"));
    CHECK_THAT(slurp(dir / "x.mesh"), Contains("\nTetrahedra\n162\n1 2 6 22 0\n"));
    write_tetmesh(m, dir / "x.msh");
    CHECK_THAT(slurp(dir / "x.msh"), Contains("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"));
    CHECK_THAT(slurp(dir / "x.msh"), Contains("$Elements\n1 162 1 162\n3 1 4 162\n1 1 2 6 22\n"));
  }
}

TEST_CASE("read_tetmesh: TetGen files, 0-based", "[io]") {
  TempDir dir;
  write_text(dir / "z.node", "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n");
  write_text(dir / "z.ele", "2 10 0\n0 0 1 2 3 9 9 9 9 9 9\n1 1 2 3 4 0 0 0 0 0 0\n");
  TetMesh m = read_tetmesh(dir / "z.node");
  CHECK(m.V == two_tets().V);
  CHECK(m.T == two_tets().T);
}

TEST_CASE("read_tetmesh: degenerate tets are errors naming the tet", "[io]") {
  TempDir dir;
  const std::string head = "MeshVersionFormatted 2\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  auto flat = write_text(dir / "flat.mesh", head + "1 1 0 0\nTetrahedra\n2\n1 2 3 4 0\n1 2 3 5 0\nEnd\n");
  REQUIRE_THROWS_AS(read_tetmesh(flat), InvalidInput);
  REQUIRE_THROWS_WITH(read_tetmesh(flat), Contains("flat.mesh: tet 1 is degenerate: volume"));
  auto rep = write_text(dir / "rep.mesh", head + "1 1 1 0\nTetrahedra\n2\n1 2 3 4 0\n2 3 4 2 0\nEnd\n");
  REQUIRE_THROWS_WITH(read_tetmesh(rep), Contains("rep.mesh: tet 1 is degenerate: repeated vertex index 1"));
}

TEST_CASE("read_tetmesh: unused vertices are dropped with a warning", "[io]") {
  TempDir dir;
  auto p = write_text(dir / "u.mesh",
                      "Dimension 3\nVertices\n6\n9 9 9 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n"
                      "Tetrahedra\n2\n2 3 4 5 0\n3 4 5 6 0\nEnd\n");
  TetReadReport r;
  TetMesh m = read_tetmesh(p, &r);
  CHECK(m.V == two_tets().V);
  CHECK(m.T == two_tets().T);
  CHECK(has_warning(r.warnings, "dropped 1 vertices used by no tet"));
}

TEST_CASE("read_tetmesh: malformed files name the file and the problem", "[io]") {
  TempDir dir;
  const std::string mv = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  const std::string vtk =
      "# vtk DataFile Version 2.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
      "0 0 0 1 0 0 0 1 0 0 0 1\n";
  const std::string g22 =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
  struct Case {
    std::string name, content, message;
  };
  const std::vector<Case> cases = {
      {"range.mesh", mv + "Tetrahedra\n1\n1 2 3 7 0\nEnd\n",
       "range.mesh: line 11: Tetrahedra entry 1: vertex index 7 out of range (4 vertices, 1-based)"},
      {"cut.mesh", mv + "Tetrahedra\n2\n1 2 3 4 0\n", "cut.mesh: line 11: truncated: unexpected end of file"},
      {"count.mesh", "Dimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 4 0\n",
       "count.mesh: line 8: expected vertex coordinate, got `Tetrahedra`"},
      {"few.mesh", "Dimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 4 0\n",
       "few.mesh: line 7: expected a section keyword, got `0` (wrong counts?)"},
      {"nan.mesh", "Dimension 3\nVertices\n1\n0 nan 0 0\n",
       "nan.mesh: line 4: vertex coordinate is not finite (`nan`)"},
      {"dim.mesh", "Dimension 2\n", "dim.mesh: line 1: Dimension 2 is not supported"},
      {"notets.mesh", mv + "End\n", "notets.mesh: no Tetrahedra section"},
      {"range.vtk", vtk + "CELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n",
       "range.vtk: cell 0: vertex index 4 out of range (4 vertices)"},
      {"size.vtk", vtk + "CELLS 1 6\n4 0 1 2 3 9\nCELL_TYPES 1\n10\n",
       "size.vtk: CELLS size is 6 but the 1 cells use 5"},
      {"types.vtk", vtk + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 2\n10\n10\n",
       "types.vtk: line 9: CELL_TYPES lists 2 cells but CELLS 1 (wrong counts)"},
      {"cut.vtk", vtk + "CELLS 1 5\n4 0 1\n",
       "cut.vtk: line 8: truncated: unexpected end of file (expected CELLS data)"},
      {"v5.vtk", vtk + "CELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\n",
       "v5.vtk: line 8: VTK 5 OFFSETS/CONNECTIVITY cells are not supported"},
      {"poly.vtk", "# vtk DataFile Version 2.0\nt\nASCII\nDATASET POLYDATA\n",
       "poly.vtk: line 4: DATASET POLYDATA is not supported (expected UNSTRUCTURED_GRID)"},
      {"header.vtk", "hello\n", "header.vtk: not a legacy VTK file"},
      {"tag.msh", g22 + "$Elements\n1\n1 4 0 1 2 3 5\n$EndElements\n",
       "tag.msh: line 13: element node tag 5 is not a node (4 vertices)"},
      {"cut.msh", g22 + "$Elements\n2\n1 4 0 1 2 3 4\n",
       "cut.msh: line 13: truncated: unexpected end of file (expected element)"},
      {"count.msh", g22 + "$Elements\n1\n1 4 0 1 2 3 4\n2 4 0 1 2 3 4\n$EndElements\n",
       "count.msh: line 14: expected $EndElements, got `2 4 0 1 2 3 4` (wrong counts?)"},
      {"bin.msh", "$MeshFormat\n2.2 1 8\n", "bin.msh: line 2: binary .msh files are not supported"},
      {"v3.msh", "$MeshFormat\n3.0 0 8\n", "v3.msh: line 2: Gmsh format version 3.0 is not supported"},
      {"nan.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 inf 0\n",
       "nan.msh: line 6: node 1 has a non-finite coordinate"},
      {"range.ele", "", "range.ele: line 2: tet 0: vertex index 6 out of range (5 vertices, first index 1)"},
      {"mesh.tet", "", "mesh.tet: unknown tet mesh extension `.tet`"},
  };
  write_text(dir / "range.node", slurp(fixture("two_tets.node")));
  for (const auto& c : cases) {
    SECTION(c.name) {
      auto p = dir / c.name;
      if (c.name == "range.ele")
        write_text(p, "1 4 0\n1 1 2 3 6\n");
      else
        write_text(p, c.content);
      REQUIRE_THROWS_WITH(read_tetmesh(p), Contains(c.message) && Contains(p.string()));
      REQUIRE_THROWS_AS(read_tetmesh(p), IOError);
    }
  }
  SECTION("truncated binary VTK") {
    write_tetmesh(tet_grid(1), dir / "b.vtk", "vtk_binary");
    std::string data = slurp(dir / "b.vtk");
    auto p = write_text(dir / "cutb.vtk", data.substr(0, data.find("CELLS") + 40));
    REQUIRE_THROWS_WITH(read_tetmesh(p), Contains("cutb.vtk: truncated: unexpected end of file in CELLS data"));
  }
  SECTION("missing file") {
    REQUIRE_THROWS_WITH(read_tetmesh(dir / "gone.mesh"), Contains("gone.mesh: no such file"));
    REQUIRE_THROWS_WITH(read_tetmesh(dir / "gone.ele"), Contains("gone.node: no such file"));
  }
}

TEST_CASE("write_hexmesh / read_hexmesh round trip; the format chooser", "[io]") {
  TempDir dir;
  HexMesh m = hex_grid(3);
  for (auto [name, format] : std::vector<std::pair<std::string, std::string>>{
           {"a.vtk", "auto"}, {"b.vtk", "vtk_binary"}, {"c.mesh", "auto"}, {"d.msh", "auto"}, {"e.out", "mesh"}}) {
    SECTION(name + " " + format) {
      write_hexmesh(m, dir / name, format);
      auto path = dir / name;
      if (name == "e.out") {
        std::filesystem::rename(path, dir / "e.mesh");
        path = dir / "e.mesh";
      }
      HexReadReport r;
      HexMesh back = read_hexmesh(path, &r);
      CHECK(back.V == m.V);
      CHECK(back.H == m.H);
      CHECK(r.hexes == 27);
      CHECK(r.vertices == 64);
    }
  }
  SECTION("fixtures") {
    for (const char* name : {"unit_hex.mesh", "unit_hex.vtk"}) {
      HexMesh h = read_hexmesh(fixture(name));
      REQUIRE(h.H.rows() == 1);
      CHECK(h.H.row(0) == (Eigen::Matrix<int, 1, 8>() << 0, 1, 2, 3, 4, 5, 6, 7).finished());
      CHECK(h.V.row(6) == Eigen::RowVector3d(1, 1, 1));
    }
  }
  SECTION("Gmsh hexes are type 5, Medit Hexahedra 1-based, VTK type 12") {
    write_hexmesh(m, dir / "x.msh");
    CHECK_THAT(slurp(dir / "x.msh"), Contains("$Elements\n1 27 1 27\n3 1 5 27\n1 1 2 6 5 17 18 22 21\n"));
    write_hexmesh(m, dir / "x.mesh");
    CHECK_THAT(slurp(dir / "x.mesh"), Contains("\nHexahedra\n27\n1 2 6 5 17 18 22 21 0\n"));
    write_hexmesh(m, dir / "x.vtk");
    CHECK_THAT(slurp(dir / "x.vtk"), Contains("\nCELLS 27 243\n8 0 1 5 4 16 17 21 20\n"));
    CHECK_THAT(slurp(dir / "x.vtk"), Contains("\nCELL_TYPES 27\n12\n"));
  }
  SECTION("errors") {
    REQUIRE_THROWS_WITH(write_hexmesh(m, dir / "x.xyz"), Contains("x.xyz: unknown extension `.xyz`"));
    REQUIRE_THROWS_AS(write_hexmesh(m, dir / "x.vtk", "stl"), ConfigError);
    REQUIRE_THROWS_WITH(write_hexmesh(m, dir / "x.vtk", "stl"), Contains("valid formats: auto, vtk, vtk_binary"));
    REQUIRE_THROWS_WITH(read_hexmesh(fixture("two_tets.vtk")), Contains("two_tets.vtk: no hexahedra"));
    REQUIRE_THROWS_WITH(read_hexmesh(fixture("two_tets.mesh")), Contains("two_tets.mesh: no Hexahedra section"));
    REQUIRE_THROWS_WITH(write_hexmesh(m, dir / "nodir" / "x.vtk"), Contains("cannot open for writing"));
  }
}

TEST_CASE("hexcheck.py reads the hex files we write", "[io][shared]") {
  const std::filesystem::path tool = std::filesystem::path(POLYHEX_SHARED_DIR) / "tools" / "hexcheck.py";
  if (!std::filesystem::exists("/usr/bin/python3") || !std::filesystem::exists(tool)) {
    WARN("skipped: /usr/bin/python3 or " << tool << " missing");
    SUCCEED();
    return;
  }
  TempDir dir;
  HexMesh m = hex_grid(3);
  for (auto [name, format] : std::vector<std::pair<std::string, std::string>>{
           {"h.vtk", "vtk"}, {"hb.vtk", "vtk_binary"}, {"h.mesh", "mesh"}}) {
    SECTION(name) {
      CellData cd;
      cd.reals.push_back({"sj", std::vector<double>(27, 1.0)});
      write_hexmesh(m, dir / name, format, cd);
      const std::string cmd = "/usr/bin/python3 " + tool.string() + " " + (dir / name).string() + " --json 2>&1";
      FILE* pipe = popen(cmd.c_str(), "r");
      REQUIRE(pipe);
      std::string out;
      char buf[4096];
      while (size_t n = fread(buf, 1, sizeof(buf), pipe)) out.append(buf, n);
      const int status = pclose(pipe);
      INFO(out);
      if (out.find("No module named") != std::string::npos) {
        WARN("skipped: hexcheck.py needs numpy/scipy");
        return;
      }
      REQUIRE(status == 0);
      auto j = nlohmann::json::parse(out);
      CHECK(j["hexes"] == 27);
      CHECK(j["vertices"] == 64);
      CHECK(j["inverted"] == 0);
      CHECK(j["volume"].get<double>() == Approx(27 * 0.7));
      CHECK(j["sj_min"].get<double>() > 0.9);
    }
  }
}
