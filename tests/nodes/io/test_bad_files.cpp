// Bad input files not covered by the format tests (test_surface_io / test_volume_io): empty files,
// files of another format, non-finite values in the remaining formats, non-orientable and
// multi-component surfaces, overlapping or touching tets.
#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"
#include "runtime/errors.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <limits>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Matchers::Contains;

namespace {

const std::string kPlyHead =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
const std::string kTetFaces = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

bool has_warning(const std::vector<std::string>& w, const std::string& text) {
  for (const auto& s : w)
    if (s.find(text) != std::string::npos) return true;
  return false;
}

// A Medit tet mesh of the given vertices (x y z per row) and 0-based tets.
std::string medit(const std::vector<std::array<double, 3>>& v, const std::vector<std::array<int, 4>>& t) {
  std::string s = "MeshVersionFormatted 2\nDimension 3\nVertices\n" + std::to_string(v.size()) + "\n";
  for (auto& p : v) s += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + " 0\n";
  s += "Tetrahedra\n" + std::to_string(t.size()) + "\n";
  for (auto& q : t)
    s += std::to_string(q[0] + 1) + " " + std::to_string(q[1] + 1) + " " + std::to_string(q[2] + 1) + " " +
         std::to_string(q[3] + 1) + " 0\n";
  return s + "End\n";
}

}  // namespace

TEST_CASE("read_surface: empty files and files of another format", "[io][badinput]") {
  TempDir dir;
  struct Case {
    std::string name, content, message;
  };
  const std::vector<Case> cases = {
      {"empty.obj", "", "empty.obj: empty file"},
      {"empty.off", "", "empty.off: empty file"},
      {"empty.stl", "", "empty.stl: empty file"},
      {"empty.ply", "", "empty.ply: empty file"},
      {"blank.obj", " \n\n\t\n", "blank.obj: empty file"},
      // An ASCII STL renamed .obj: no OBJ statement at all.
      {"stl.obj",
       "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
       "endfacet\nendsolid t\n",
       "stl.obj: no faces (`f` lines) and no vertices (`v` lines): not an OBJ file?"},
      {"points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "points.obj: no faces (`f` lines)"},
      {"stl.off", "solid t\nendsolid t\n", "stl.off: line 1: not an OFF file (expected the header `OFF`, got `solid`)"},
      {"off.ply", "OFF\n4 4 0\n", "off.ply"},
      {"off.stl", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + kTetFaces, "off.stl"},
      {"nan.ply", kPlyHead + "0 0 0\n1 nan 0\n0 1 0\n0 0 1\n" + kTetFaces,
       "nan.ply: vertex 1 has a non-finite coordinate"},
      {"inf.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 -inf 0\n",
       "inf.stl: line 5: vertex has a non-finite coordinate (`-inf`)"},
      {"neg.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 -1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
       "neg.ply: face 0: bad vertex index"},
      {"noext", "OFF\n", "noext: unknown surface extension ``"},
  };
  for (const auto& c : cases) {
    SECTION(c.name) {
      auto p = write_text(dir / c.name, c.content);
      REQUIRE_THROWS_AS(read_surface(p), IOError);
      REQUIRE_THROWS_WITH(read_surface(p), Contains(c.message) && Contains(p.string()));
    }
  }
  SECTION("NaN in binary PLY") {
    std::string data =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
    const float xyz[12] = {0, 0, 0, 1, 0, 0, 0, std::numeric_limits<float>::infinity(), 0, 0, 0, 1};
    data.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
    auto p = write_text(dir / "inf_bin.ply", data);
    REQUIRE_THROWS_WITH(read_surface(p), Contains("inf_bin.ply: vertex 2 has a non-finite coordinate"));
  }
}

TEST_CASE("read_surface: a closed non-orientable surface is refused", "[io][badinput]") {
  // The 6-vertex triangulation of the projective plane: every edge in exactly 2 triangles, every
  // vertex link a single cycle, but no consistent orientation exists.
  TempDir dir;
  std::string s = "v 1 0 0\nv 0 1 0\nv 0 0 1\nv -1 0.2 0.1\nv 0.3 -1 0.2\nv 0.1 0.4 -1\n";
  for (const char* f : {"1 2 3", "1 3 4", "1 4 5", "1 5 6", "1 6 2", "2 3 5", "3 4 6", "4 5 2", "5 6 3", "6 2 4"})
    s += std::string("f ") + f + "\n";
  auto p = write_text(dir / "rp2.obj", s);
  REQUIRE_THROWS_AS(read_surface(p), InvalidInput);
  REQUIRE_THROWS_WITH(read_surface(p),
                      Contains(p.string() + ": surface is not orientable (no consistent orientation exists)"));
}

TEST_CASE("read_surface: several components are meshed, with a warning", "[io][badinput]") {
  TempDir dir;
  auto p = write_text(dir / "two.off",
                      "OFF\n8 8 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n5 0 0\n6 0 0\n5 1 0\n5 0 1\n"
                      "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 4 6 5\n3 4 5 7\n3 4 7 6\n3 5 6 7\n");
  SurfaceReadReport r;
  read_surface(p, &r);
  CHECK(r.components == 2);
  CHECK(has_warning(r.warnings, "two.off: 2 connected components: all are meshed"));
  SurfaceReadReport one;
  read_surface(write_text(dir / "one.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + kTetFaces), &one);
  CHECK(one.components == 1);
  CHECK_FALSE(has_warning(one.warnings, "connected components"));
}

TEST_CASE("read_tetmesh: overlapping tets and a boundary that is not a manifold are refused", "[io][badinput]") {
  TempDir dir;
  const std::vector<std::array<double, 3>> base = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  struct Case {
    std::string name;
    std::vector<std::array<double, 3>> extra;
    std::vector<std::array<int, 4>> tets;
    std::string message;
  };
  const std::vector<Case> cases = {
      // Three tets on the face (0 1 2): two above it, one below.
      {"three.mesh",
       {{0.2, 0.2, 0.5}, {0.3, 0.3, -1}},
       {{0, 1, 2, 3}, {0, 1, 2, 4}, {0, 1, 2, 5}},
       "three.mesh: face (0, 1, 2) is shared by 3 tets (0, 1, 2, ...): the tets overlap"},
      // Two tets on the same side of their shared face.
      {"fold.mesh",
       {{0.2, 0.2, 0.5}},
       {{0, 1, 2, 3}, {0, 1, 2, 4}},
       "fold.mesh: tets 0 and 1 lie on the same side of their shared face (0, 1, 2): the tets overlap"},
      // Two tets sharing only the edge 0-1: the boundary is closed but that edge is in 4 faces.
      {"edge.mesh",
       {{0, -1, 0}, {0, 0, -1}},
       {{0, 1, 2, 3}, {0, 1, 5, 4}},
       "edge.mesh: boundary: non-manifold: 1 edges are used by more than 2 triangles"},
      // Two tets sharing only vertex 0: a pinch point.
      {"pinch.mesh",
       {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}},
       {{0, 1, 2, 3}, {0, 4, 6, 5}},
       "pinch.mesh: boundary: non-manifold vertex (0.000000, 0.000000, 0.000000)"},
  };
  for (const auto& c : cases) {
    SECTION(c.name) {
      auto v = base;
      v.insert(v.end(), c.extra.begin(), c.extra.end());
      auto p = write_text(dir / c.name, medit(v, c.tets));
      REQUIRE_THROWS_AS(read_tetmesh(p), InvalidInput);
      REQUIRE_THROWS_WITH(read_tetmesh(p), Contains(c.message) && Contains(p.string()));
    }
  }
  SECTION("an inverted tet is re-oriented, a zero-volume one refused, a valid mesh counts its boundary") {
    // Tet 1 inverted: re-oriented, and then the two tets are on opposite sides of their face.
    auto p = write_text(dir / "inv.mesh",
                        medit({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}}, {{0, 1, 2, 3}, {1, 3, 2, 4}}));
    TetReadReport r;
    TetMesh m = read_tetmesh(p, &r);
    CHECK(r.reoriented == 1);
    CHECK(r.boundary_faces == 6);
    CHECK(tet_volume(m.V, m.T.row(1)) > 0);
    auto z = write_text(dir / "zero.mesh", medit({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5, 0.5, 0}},
                                                 {{0, 1, 2, 3}, {0, 1, 2, 4}}));
    CHECK_THROWS_WITH(read_tetmesh(z), Contains("zero.mesh: tet 1 is degenerate: volume"));
  }
}
