#include "nodes/formats/surface_io.h"
#include "runtime/errors.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cstring>

using namespace polyhex;
using namespace polyhex::iotest;
using Catch::Contains;

namespace {

void require_valid(const SurfaceMesh& m, const SurfaceReadReport& r, int nv, int nf, double volume) {
  CHECK(m.V.rows() == nv);
  CHECK(m.F.rows() == nf);
  CHECK(r.vertices == nv);
  CHECK(r.faces == nf);
  CHECK(r.components == 1);
  CHECK(r.genus == 0);
  CHECK(signed_volume(m) == Approx(volume));
  auto [repeated, unmatched] = orientation_defects(m);
  CHECK(repeated == 0);
  CHECK(unmatched == 0);
}

bool has_warning(const SurfaceReadReport& r, const std::string& part) {
  for (auto& w : r.warnings)
    if (w.find(part) != std::string::npos) return true;
  return false;
}

// The unit cube as 12 triangles, outward, in binary STL (corners unwelded), optionally with the
// header starting with "solid" as some exporters write.
std::string binary_stl_cube(bool solid_header, bool inward) {
  const float P[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int Q[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  std::string out(80, ' ');
  if (solid_header) std::memcpy(out.data(), "solid cube exported", 19);
  uint32_t n = 12;
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (auto& q : Q)
    for (int t = 0; t < 2; ++t) {
      int tri[3] = {q[0], q[1 + t], q[2 + t]};
      if (inward) std::swap(tri[1], tri[2]);
      float rec[12] = {0, 0, 0};
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) rec[3 + 3 * k + c] = P[tri[k]][c];
      out.append(reinterpret_cast<const char*>(rec), sizeof(rec));
      out.append(2, '\0');
    }
  return out;
}

// The unit cube as binary PLY with extra properties and an extra element, in either byte order.
std::string binary_ply_cube(bool big_endian) {
  auto put = [big_endian](std::string& s, auto v) {
    char b[sizeof(v)];
    std::memcpy(b, &v, sizeof(v));
    if (big_endian) std::reverse(b, b + sizeof(v));
    s.append(b, sizeof(v));
  };
  std::string s = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\nelement vertex 8\nproperty double x\nproperty double y\nproperty double z\n"
                  "property list uchar int extra\nproperty ushort label\n"
                  "element face 6\nproperty list uchar uint vertex_indices\nproperty float weight\n"
                  "element material 1\nproperty short id\nend_header\n";
  const double P[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const uint32_t Q[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  for (int v = 0; v < 8; ++v) {
    for (double x : P[v]) put(s, x);
    put(s, uint8_t(v % 3));
    for (int k = 0; k < v % 3; ++k) put(s, int32_t(1000 + k));
    put(s, uint16_t(v));
  }
  for (auto& q : Q) {
    put(s, uint8_t(4));
    for (uint32_t i : q) put(s, i);
    put(s, 0.5f);
  }
  put(s, int16_t(3));
  return s;
}

}  // namespace

TEST_CASE("read_surface: OBJ with v/t/n forms and negative indices", "[io]") {
  SurfaceReadReport r;
  SurfaceMesh m = read_surface(fixture("tetra.obj"), &r);
  require_valid(m, r, 4, 4, 1.0 / 6.0);
  CHECK(r.flipped == 0);
  CHECK(r.welded == 0);
  CHECK(r.warnings.empty());
  CHECK(m.source == fixture("tetra.obj").string());
}

TEST_CASE("read_surface: OBJ and OFF quads are fan-triangulated with a warning", "[io]") {
  for (const char* name : {"cube_quads.obj", "cube.off", "cube_ascii.ply"}) {
    SECTION(name) {
      SurfaceReadReport r;
      SurfaceMesh m = read_surface(fixture(name), &r);
      require_valid(m, r, 8, 12, 1.0);
      CHECK(r.flipped == 0);
      CHECK(has_warning(r, "fan-triangulated 6 polygons"));
    }
  }
}

TEST_CASE("read_surface: ASCII STL is welded, with a warning", "[io]") {
  SurfaceReadReport r;
  SurfaceMesh m = read_surface(fixture("tetra_ascii.stl"), &r);
  require_valid(m, r, 4, 4, 1.0 / 6.0);
  CHECK(r.welded == 8);
  CHECK(has_warning(r, "welded 8 duplicate vertices"));
}

TEST_CASE("read_surface: binary STL, also with a `solid` header, is welded; inward is flipped", "[io]") {
  TempDir dir;
  SECTION("plain header") {
    SurfaceReadReport r;
    SurfaceMesh m = read_surface(write_text(dir / "cube.stl", binary_stl_cube(false, false)), &r);
    require_valid(m, r, 8, 12, 1.0);
    CHECK(r.welded == 28);
    CHECK(r.flipped == 0);
  }
  SECTION("header starting with solid, inward oriented") {
    SurfaceReadReport r;
    SurfaceMesh m = read_surface(write_text(dir / "CUBE.STL", binary_stl_cube(true, true)), &r);
    require_valid(m, r, 8, 12, 1.0);
    CHECK(r.flipped == 12);
    CHECK(has_warning(r, "flipped all triangles to face outward"));
  }
}

TEST_CASE("read_surface: binary PLY in both byte orders skips other properties and elements", "[io]") {
  TempDir dir;
  for (bool big : {false, true}) {
    SurfaceReadReport r;
    SurfaceMesh m = read_surface(write_text(dir / (big ? "be.ply" : "le.ply"), binary_ply_cube(big)), &r);
    require_valid(m, r, 8, 12, 1.0);
    CHECK(m.V(6, 0) == 1.0);
    CHECK(m.V(6, 2) == 1.0);
  }
}

TEST_CASE("read_surface: inconsistent faces are re-oriented with a warning", "[io]") {
  TempDir dir;
  // The tetrahedron with its slanted face written backwards.
  auto p = write_text(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n");
  SurfaceReadReport r;
  SurfaceMesh m = read_surface(p, &r);
  require_valid(m, r, 4, 4, 1.0 / 6.0);
  CHECK(r.flipped == 1);
  CHECK(has_warning(r, "flipped 1 of 4 triangles"));
}

TEST_CASE("read_surface: an OBJ closed only once duplicates are welded is welded", "[io]") {
  TempDir dir;
  // Vertex 5 duplicates vertex 1.
  auto p = write_text(dir / "dup.obj",
                      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0 0 0\nv 7 7 7\nf 1 3 2\nf 5 2 4\nf 1 4 3\nf 2 3 4\n");
  SurfaceReadReport r;
  SurfaceMesh m = read_surface(p, &r);
  require_valid(m, r, 4, 4, 1.0 / 6.0);
  CHECK(r.welded == 1);
  CHECK(has_warning(r, "dropped 1 unused vertices"));
  CHECK(has_warning(r, "welded 1 duplicate vertices (the surface is open without it)"));
}

TEST_CASE("read_surface: two disjoint tetrahedra are two components", "[io]") {
  TempDir dir;
  auto p = write_text(dir / "two.off",
                      "OFF\n8 8 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n5 0 0\n6 0 0\n5 1 0\n5 0 1\n"
                      "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 4 6 5\n3 4 5 7\n3 4 7 6\n3 5 6 7\n");
  SurfaceReadReport r;
  SurfaceMesh m = read_surface(p, &r);
  CHECK(r.components == 2);
  CHECK(r.genus == 0);
  CHECK(signed_volume(m) == Approx(2.0 / 6.0));
}

TEST_CASE("read_surface: malformed files name the file and the problem", "[io]") {
  TempDir dir;
  const std::string tet_v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  struct Case {
    std::string name, content, message;
  };
  const std::vector<Case> cases = {
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "nan.obj: line 2: vertex 2 has a non-finite coordinate"},
      {"inf.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", "inf.off: line 4: vertex 1 has a non-finite"},
      {"range.obj", tet_v + "f 1 3 2\nf 1 2 9\n", "range.obj: line 6: vertex index 9 out of range (4 vertices)"},
      {"zero.obj", tet_v + "f 1 3 0\n", "zero.obj: line 5: vertex index 0 (OBJ indices start at 1)"},
      {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
       "range.off: line 6: face 0: vertex index 3 out of range (3 vertices)"},
      {"short.off", "OFF\n8 6 0\n0 0 0\n1 0 0\n", "short.off: line 4: truncated: the header announces 8 vertices"},
      {"faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "truncated: the header announces 2 faces"},
      {"extra.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
       "extra.off: line 7: more data after the 1 faces the header announces (wrong counts?)"},
      {"counts.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
       "counts.off: line 6: truncated: the header announces 1 faces, the file ends after 0"},
      {"header.off", "PLY\n3 1 0\n", "header.off: line 1: not an OFF file"},
      {"open.obj", tet_v + "f 1 3 2\nf 1 2 4\nf 1 4 3\n",
       "open.obj: surface is not closed: 3 boundary edges (used by only one triangle)"},
      {"repeat.obj", tet_v + "f 1 3 2\nf 1 2 2\n", "repeat.obj: face 1 (line 6) is degenerate: repeated vertex index"},
      {"flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
       "flat.obj: face 0 (line 5) is degenerate: zero area"},
      // Two tetrahedra sharing the edge 0-1: that edge is in 4 triangles.
      {"edge.obj",
       tet_v + "v 0 -1 0\nv 0 0 -1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 5 2\nf 1 2 6\nf 1 6 5\nf 2 5 6\n",
       "edge.obj: non-manifold: 1 edges are used by more than 2 triangles"},
      // Two tetrahedra sharing vertex 0 only: closed and edge-manifold, but a pinch point.
      {"pinch.obj",
       tet_v + "v -1 0 0\nv 0 -1 0\nv 0 0 -1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 5 6\nf 1 6 7\nf 1 7 5\nf 5 7 6\n",
       "pinch.obj: non-manifold vertex (0.000000, 0.000000, 0.000000): its triangles form more than one fan"},
      {"cut.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
       "cut.stl: line 5: truncated: the file ends inside a facet"},
      {"noend.stl",
       "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n",
       "noend.stl: line 8: truncated: no `endsolid`"},
      {"tiny.stl", "abc", "tiny.stl: truncated: 3 bytes is too short for a binary STL"},
      {"wrong.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
       "wrong.ply: line 14: more data after the elements the header announces (wrong counts?)"},
      {"range.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
       "range.ply: line 13: triangle 0: vertex index 5 out of range (3 vertices)"},
      {"cut.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n",
       "cut.ply: line 11: truncated: unexpected end of file (expected vertex 2)"},
      {"noheader.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "noheader.ply: truncated: no `end_header`"},
      {"mesh.xyz", "1 2 3\n", "mesh.xyz: unknown surface extension `.xyz` (expected .obj, .off, .stl or .ply)"},
  };
  for (const auto& c : cases) {
    SECTION(c.name) {
      auto p = write_text(dir / c.name, c.content);
      REQUIRE_THROWS_WITH(read_surface(p), Contains(c.message) && Contains(p.string()));
    }
  }
  SECTION("error kinds") {
    CHECK_THROWS_AS(read_surface(write_text(dir / "o.obj", tet_v + "f 1 3 2\n")), InvalidInput);
    CHECK_THROWS_AS(read_surface(write_text(dir / "n.obj", "v 0 nan 0\n")), IOError);
  }
  SECTION("missing file") {
    REQUIRE_THROWS_AS(read_surface(dir / "nothere.off"), IOError);
    REQUIRE_THROWS_WITH(read_surface(dir / "nothere.off"), Contains("nothere.off: no such file"));
  }
  SECTION("truncated binary STL") {
    std::string data = binary_stl_cube(false, false);
    auto p = write_text(dir / "cut_bin.stl", data.substr(0, data.size() - 20));
    REQUIRE_THROWS_WITH(read_surface(p), Contains("cut_bin.stl: truncated or corrupt binary STL: size 664 bytes, "
                                                  "but 12 triangles need 84 + 50 * 12 = 684"));
    std::string solid = binary_stl_cube(true, false);
    auto q = write_text(dir / "cut_solid.stl", solid.substr(0, solid.size() - 1));
    REQUIRE_THROWS_WITH(read_surface(q), Contains("cut_solid.stl: truncated or corrupt binary STL"));
  }
  SECTION("truncated binary PLY") {
    std::string data = binary_ply_cube(false);
    auto p = write_text(dir / "cut_bin.ply", data.substr(0, data.size() - 30));
    REQUIRE_THROWS_WITH(read_surface(p), Contains("cut_bin.ply: truncated: unexpected end of file in face"));
  }
  SECTION("NaN in binary STL") {
    std::string data = binary_stl_cube(false, false);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(data.data() + 84 + 50 * 3 + 12 + 4, &nan, 4);
    auto p = write_text(dir / "nan.stl", data);
    REQUIRE_THROWS_WITH(read_surface(p), Contains("nan.stl: triangle 3 has a non-finite coordinate"));
  }
}

TEST_CASE("read_surface: shape:NAME builds a built-in shape and checks it", "[io]") {
  SurfaceReadReport r;
  SurfaceMesh m = read_surface("shape:torus", &r);
  CHECK(r.genus == 1);
  CHECK(r.components == 1);
  CHECK(r.faces == m.F.rows());
  CHECK(signed_volume(m) > 0);
  REQUIRE_THROWS_AS(read_surface("shape:no_such_shape"), InvalidInput);
}

TEST_CASE("write_surface: OBJ and OFF round trips are exact; VTK carries cell data", "[io]") {
  TempDir dir;
  SurfaceMesh m = read_surface(fixture("cube_quads.obj"));
  m.V.col(0) *= 0.1;  // not exactly representable in short decimals
  m.V.col(2).array() += 1e-7;
  for (const char* name : {"out.obj", "out.off"}) {
    write_surface(m, dir / name);
    SurfaceReadReport r;
    SurfaceMesh back = read_surface(dir / name, &r);
    CHECK(back.V == m.V);
    CHECK(back.F == m.F);
    CHECK(r.warnings.empty());
  }
  CellData cd;
  cd.ints.push_back({"chart", std::vector<int>(12, 3)});
  cd.ints.push_back({"axis", {0, 0, 1, 1, 2, 2, 0, 0, 1, 1, 2, 2}});
  write_surface(m, dir / "out.vtk", cd);
  std::ifstream in(dir / "out.vtk");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(text.rfind("# vtk DataFile Version 2.0\n", 0) == 0);
  CHECK_THAT(text, Contains("DATASET POLYDATA\nPOINTS 8 double\n"));
  CHECK_THAT(text, Contains("POLYGONS 12 48\n3 "));
  CHECK_THAT(text, Contains("CELL_DATA 12\nSCALARS chart int 1\nLOOKUP_TABLE default\n3\n3\n"));
  CHECK_THAT(text, Contains("SCALARS axis int 1\nLOOKUP_TABLE default\n0\n0\n1\n1\n2\n"));
  cd.ints[1].second.pop_back();
  REQUIRE_THROWS_WITH(write_surface(m, dir / "bad.vtk", cd), Contains("cell data `axis` has 11 values for 12 cells"));
  REQUIRE_THROWS_WITH(write_surface(m, dir / "bad.stl"), Contains("bad.stl: unknown surface extension `.stl`"));
  CHECK(!std::filesystem::exists(dir / "bad.vtk"));
}

TEST_CASE("read_surface: a 50k-triangle OFF torus reads back with its counts, genus and volume", "[io]") {
  TempDir dir;
  // A closed 100 x 250 torus grid: 25000 vertices, 50000 triangles, genus 1.
  const int nu = 100, nv = 250;
  SurfaceMesh m;
  m.V.resize(nu * nv, 3);
  m.F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      m.V.row(i * nv + j) << (3 + std::cos(u)) * std::cos(v), (3 + std::cos(u)) * std::sin(v), std::sin(u);
      int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
          d = i * nv + (j + 1) % nv;
      m.F.row(2 * a) << a, b, c;
      m.F.row(2 * a + 1) << a, c, d;
    }
  write_surface(m, dir / "torus.off");
  // (Speed is measured by benchmarks, not asserted here.)
  SurfaceReadReport r;
  SurfaceMesh back = read_surface(dir / "torus.off", &r);
  CHECK(r.faces == 50000);
  CHECK(r.genus == 1);
  CHECK(std::abs(signed_volume(back)) == Approx(2 * M_PI * M_PI * 3).epsilon(0.01));
  CHECK(signed_volume(back) > 0);
}
