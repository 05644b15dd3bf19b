#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"
#include "tests/helpers/io_checks.h"

#include <catch2/catch.hpp>

#include <chrono>

using namespace polyhex;
using namespace polyhex::iotest;

namespace {
struct Expected {
  const char* name;
  int triangles, vertices, genus;
};
// Counts from ../shared/data/README.md (girl.off is self-intersecting but a valid closed manifold).
const Expected kSurfaces[] = {
    {"bunny.off", 6966, 3485, 0},
    {"fandisk.off", 14454, 7229, 0},
    {"fertility.off", 9000, 4494, 4},
    {"elephant.obj", 12064, 6034, 0},
    {"rockerarm.obj", 20088, 10044, 1},
    {"bumpy_torus.obj", 36248, 18124, 1},
    {"casting.off", 10224, 5096, 9},
    {"girl.off", 19820, 9912, 0},
    {"femur.obj", 7798, 3897, 2},
    {"hand.off", 27960, 13982, 0},
    {"dragon.off", 42084, 21042, 1},
    {"kitten.off", 20366, 10183, 1},
    {"chinese_lion.off", 50384, 25194, 0},
    {"greek_sculpture.off", 25014, 12501, 4},
    {"carter.stl", 24710, 12343, 7},
    {"bimba.stl", 24640, 12322, 0},
    {"joint.obj", 41808, 20902, 2},
    {"block.obj", 17550, 8771, 3},
    {"mambo_B0.obj", 19964, 9984, 0},
    {"mambo_S3.off", 7190, 3593, 2},
    {"encrusted_cube.obj", 49642, 24823, 0},
    {"7-connected.stl", 36, 20, 0},
    {"8-connected.stl", 46, 25, 0},
    {"conjoined_twins.stl", 34, 19, 0},
    {"cuboid_screw_thread.stl", 108, 56, 0},
    {"cuboid_torus_with_step.stl", 52, 26, 1},
    {"cuboid_tray_with_step.stl", 48, 26, 0},
    {"in-volume_knot.stl", 144, 72, 1},
    {"in-volume_twist.stl", 1752, 874, 2},
};

std::filesystem::path shared_data() { return std::filesystem::path(POLYHEX_SHARED_DIR) / "data"; }
}  // namespace

TEST_CASE("read_surface reads every shared surface with the README's counts", "[io][shared]") {
  if (!std::filesystem::exists(shared_data() / "surfaces")) {
    WARN("skipped: " << shared_data() << " missing");
    SUCCEED();
    return;
  }
  size_t files = 0;
  for (auto& entry : std::filesystem::directory_iterator(shared_data() / "surfaces")) {
    (void)entry;
    ++files;
  }
  CHECK(files == std::size(kSurfaces));
  double slowest = 0;
  for (const Expected& e : kSurfaces) {
    SECTION(e.name) {
      const auto path = shared_data() / "surfaces" / e.name;
      auto t0 = std::chrono::steady_clock::now();
      SurfaceReadReport r;
      SurfaceMesh m = read_surface(path, &r);
      slowest = std::max(slowest, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      INFO(e.name);
      CHECK(m.F.rows() == e.triangles);
      CHECK(m.V.rows() == e.vertices);
      CHECK(r.genus == e.genus);
      CHECK(r.components == 1);
      CHECK(r.flipped == 0);  // all are consistently and outward oriented
      CHECK(signed_volume(m) > 0);
      const bool stl = std::string(e.name).find(".stl") != std::string::npos;
      if (stl)
        CHECK(r.welded == 3 * e.triangles - e.vertices);
      else
        CHECK(r.welded == 0);
      CHECK(slowest < 1.0);
    }
  }
}

TEST_CASE("read_tetmesh reads both shared tet meshes with the README's counts", "[io][shared]") {
  if (!std::filesystem::exists(shared_data() / "tets")) {
    WARN("skipped: " << shared_data() << " missing");
    SUCCEED();
    return;
  }
  struct {
    const char* name;
    int tets, vertices;
  } meshes[] = {{"mambo_B0.mesh", 4365, 999}, {"mambo_S3.mesh", 43220, 9009}};
  for (auto& e : meshes) {
    TetReadReport r;
    TetMesh m = read_tetmesh(shared_data() / "tets" / e.name, &r);
    INFO(e.name);
    CHECK(m.T.rows() == e.tets);
    CHECK(m.V.rows() == e.vertices);
    double vol = 0;
    for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
      const double v = tet_volume(m.V, m.T.row(t));
      CHECK(v > 0);
      vol += v;
    }
    CHECK(vol > 0);
    WARN(e.name << ": re-oriented " << r.reoriented << " tets; volume " << vol);
  }
}
