// Tests of the rotation-driven deformation (paper §4): building blocks, known answers on generated
// shapes, failure paths, the node binding, and a [shared] run over real models.
#include "graph/node.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/formats/surface_io.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "runtime/errors.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <filesystem>
#include <random>

using namespace polyhex;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Structured tet mesh of the box [0,nx*s] x [0,ny*s] x [0,nz*s]: every cube split into the 6
/// tets around its main diagonal (Kuhn subdivision, conforming across cubes), positively oriented.
TetMesh box_mesh(int nx, int ny, int nz, double s = 1.0) {
  TetMesh m;
  auto id = [&](int x, int y, int z) { return (z * (ny + 1) + y) * (nx + 1) + x; };
  m.V.resize((nx + 1) * (ny + 1) * (nz + 1), 3);
  for (int z = 0; z <= nz; ++z)
    for (int y = 0; y <= ny; ++y)
      for (int x = 0; x <= nx; ++x) m.V.row(id(x, y, z)) << x * s, y * s, z * s;
  const std::array<std::array<int, 3>, 6> perms = {{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  std::vector<std::array<int, 4>> tets;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (auto& p : perms) {
          std::array<int, 3> c = {x, y, z};
          std::array<int, 4> t;
          t[0] = id(c[0], c[1], c[2]);
          for (int k = 0; k < 3; ++k) {
            c[p[k]] += 1;
            t[k + 1] = id(c[0], c[1], c[2]);
          }
          tets.push_back(t);
        }
  m.T.resize(tets.size(), 4);
  for (size_t t = 0; t < tets.size(); ++t) {
    auto v = tets[t];
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (m.V.row(v[k + 1]) - m.V.row(v[0])).transpose();
    if (D.determinant() < 0) std::swap(v[2], v[3]);
    for (int k = 0; k < 4; ++k) m.T(t, k) = v[k];
  }
  m.source = "box";
  return m;
}

double signed_volume(const TetMesh& m) {
  double vol = 0;
  for (int t = 0; t < m.T.rows(); ++t) {
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (m.V.row(m.T(t, k + 1)) - m.V.row(m.T(t, 0))).transpose();
    vol += D.determinant() / 6;
  }
  return vol;
}

/// The 24 proper cube symmetries (signed permutation matrices with det +1).
std::vector<Eigen::Matrix3d> cube_symmetries() {
  std::vector<Eigen::Matrix3d> out;
  const std::array<std::array<int, 3>, 6> perms = {{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (auto& p : perms)
    for (int s = 0; s < 8; ++s) {
      Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
      for (int j = 0; j < 3; ++j) P(p[j], j) = (s >> j) & 1 ? -1.0 : 1.0;
      if (P.determinant() > 0) out.push_back(P);
    }
  return out;
}

Eigen::Matrix3d quat_matrix(const Eigen::Vector4d& q) {
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).toRotationMatrix();
}

/// Tets of a built-in shape (nodes/shapes).
TetMesh shape_tets(const char* name, int resolution, double edge_length) {
  ShapeParams sp;
  sp.name = name;
  sp.resolution = resolution;
  TetgenParams tp;
  tp.edge_length = edge_length;
  return tetrahedralize(make_shape(sp), tp);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Building blocks

TEST_CASE("rotation: coherent orientation picks the cube-equivalent closest to identity, q_w > 0", "[rotation]") {
  const auto syms = cube_symmetries();
  REQUIRE(syms.size() == 24);
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  double min_w = 1;
  for (int trial = 0; trial < 3000; ++trial) {
    const Eigen::Matrix3d R = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    const Eigen::Vector4d q = coherent_quaternion(R);
    CHECK(std::abs(q.norm() - 1) < 1e-12);
    REQUIRE(q[3] > 0);
    min_w = std::min(min_w, q[3]);
    // q is R P for a proper cube symmetry P ...
    const Eigen::Matrix3d P = R.transpose() * quat_matrix(q);
    double best_sym_err = 1e9;
    for (auto& S : syms) best_sym_err = std::min(best_sym_err, (P - S).cwiseAbs().maxCoeff());
    REQUIRE(best_sym_err < 1e-9);
    // ... with the largest |w| among all 24 equivalents.
    double best_w = 0;
    for (auto& S : syms) best_w = std::max(best_w, std::abs(Eigen::Quaterniond(Eigen::Matrix3d(R * S)).w()));
    REQUIRE(q[3] >= best_w - 1e-12);
  }
  // The covering radius of the cube group bounds the angle to the closest equivalent by ~62.8°.
  CHECK(min_w > 0.85);
}

TEST_CASE("rotation: minimal axis-aligning rotation maps the normal to its closest axis", "[rotation]") {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int trial = 0; trial < 3000; ++trial) {
    const Eigen::Vector3d n = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Matrix3d R = axis_aligning_rotation(n);
    CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK(R.determinant() == Approx(1.0).epsilon(1e-12));
    int k = 0;
    n.cwiseAbs().maxCoeff(&k);
    Eigen::Vector3d a = Eigen::Vector3d::Zero();
    a[k] = n[k] > 0 ? 1 : -1;
    REQUIRE((R * n - a).norm() < 1e-12);
    // Angle at most acos(1/sqrt 3) = 54.74°, and it is already the coherent choice (P = I).
    const double angle = std::acos(std::min(1.0, (R.trace() - 1) / 2));
    CHECK(angle <= std::acos(1 / std::sqrt(3.0)) + 1e-12);
    REQUIRE((quat_matrix(coherent_quaternion(R)) - R).cwiseAbs().maxCoeff() < 1e-9);
  }
  CHECK((axis_aligning_rotation(Eigen::Vector3d(0, 0, -1)) - Eigen::Matrix3d::Identity()).norm() < 1e-15);
}

TEST_CASE("rotation: boundary faces of a box are the outward surface triangles", "[rotation]") {
  const TetMesh box = box_mesh(4, 3, 2, 0.5);
  const RowMatrixX3i F = boundary_faces(box.T, static_cast<int>(box.V.rows()));
  CHECK(F.rows() == 2 * 2 * (4 * 3 + 3 * 2 + 4 * 2));
  // Divergence theorem: sum of (a . (b x c)) / 6 over outward faces = enclosed volume.
  double vol = 0;
  for (int f = 0; f < F.rows(); ++f) vol += box.V.row(F(f, 0)).dot(box.V.row(F(f, 1)).cross(box.V.row(F(f, 2)))) / 6;
  CHECK(vol == Approx(2.0 * 1.5 * 1.0).epsilon(1e-12));
  CHECK(signed_volume(box) == Approx(3.0).epsilon(1e-12));
  CHECK(axis_alignment(box.V, F) == Approx(1.0));
  // Rotated by 45° about z: only the top and bottom (2 x 1.5 each) stay aligned.
  RowMatrixX3d Vr = box.V * Eigen::AngleAxisd(kPi / 4, Eigen::Vector3d::UnitZ()).toRotationMatrix().transpose();
  const double top_bottom = 2 * 2.0 * 1.5, sides = 2 * (2.0 * 1.0 + 1.5 * 1.0);
  CHECK(axis_alignment(Vr, F) == Approx(top_bottom / (top_bottom + sides)).epsilon(1e-12));
}

// ---------------------------------------------------------------------------------------------
// Known answers

TEST_CASE("rotation: an axis-aligned box stays where it is", "[rotation]") {
  const TetMesh box = box_mesh(5, 4, 3, 0.25);
  RotationDeformParams p;
  int calls = 0;
  auto r = rotation_deform(box, p, [&](int k, const TetMesh& m, const RotationIterationStats& s) {
    ++calls;
    CHECK(k == calls);
    CHECK(m.T.rows() == box.T.rows());
    CHECK(s.alignment == Approx(1.0));
  });
  CHECK(calls == 5);
  REQUIRE(r.iterations.size() == 5);
  CHECK(r.input_alignment == Approx(1.0));
  CHECK((r.mesh.T - box.T).cwiseAbs().maxCoeff() == 0);
  CHECK(r.mesh.source == box.source);
  CHECK((r.mesh.V - box.V).cwiseAbs().maxCoeff() < 1e-9);  // the pin does not move
  for (auto& s : r.iterations) {
    CHECK(s.alignment == Approx(1.0));
    CHECK(s.inverted_tets == 0);
    CHECK(s.distortion == Approx(1.0).epsilon(1e-9));
    CHECK(s.volume_ratio == Approx(1.0).epsilon(1e-9));
    CHECK(s.min_quaternion_norm == Approx(1.0).epsilon(1e-9));
    CHECK(s.feature_vertices > 0);  // the box edges and corners
  }
  CHECK(r.components == 1);
  CHECK(r.boundary_faces == 2 * 2 * (5 * 4 + 4 * 3 + 5 * 3));
  // Factor each system once, 4 + 3 columns per iteration.
  CHECK(r.factor_stats.factorizations == 2);
  CHECK(r.factor_stats.analyses == 1);  // shared by both systems
  CHECK(r.factor_stats.solves == 5 * 7);
}

TEST_CASE("rotation: a box rotated by 20 degrees comes back axis-aligned with its volume", "[rotation]") {
  TetMesh box = box_mesh(8, 6, 4, 0.25);
  box.V = box.V * Eigen::AngleAxisd(20 * kPi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix().transpose();
  const double vol0 = signed_volume(box);
  RotationDeformParams p;
  auto r = rotation_deform(box, p);
  CHECK(r.input_alignment < 0.5);
  for (auto& s : r.iterations) {
    CHECK(s.inverted_tets == 0);
    CHECK(s.min_quaternion_norm > 0.9);
  }
  CHECK(r.iterations.back().alignment >= 0.95);
  CHECK(std::abs(signed_volume(r.mesh) / vol0 - 1) < 0.01);
  CHECK(r.iterations.back().volume_ratio == Approx(signed_volume(r.mesh) / vol0).epsilon(1e-9));
  CHECK(r.factor_stats.factorizations == 2);
}

TEST_CASE("rotation: a sphere gains alignment monotonically, no degenerate quaternion", "[rotation]") {
  const TetMesh sphere = shape_tets("sphere", 24, 0.06);
  RotationDeformParams p;
  auto r = rotation_deform(sphere, p);
  double prev = r.input_alignment;
  for (auto& s : r.iterations) {
    CHECK(s.alignment > prev);
    prev = s.alignment;
    CHECK(s.min_quaternion_norm > 0.1);
    // A sphere pushed towards a cube squeezes a few tets at the emerging corners.
    CHECK(s.inverted_tets <= sphere.T.rows() / 1000);
  }
  CHECK(r.iterations.back().alignment > r.input_alignment + 0.2);
  CHECK(r.factor_stats.factorizations == 2);
}

// The surface flattening (flatten = β): a box whose top face carries a smooth bump a few tets wide.
// Every top vertex's normal is closest to +Z, so with β = 1 the top edges' targets lose their Z part
// and the bump goes; the paper's Eq. 1 (β = 0) rotates the bump's flanks but keeps most of its height
// (the 15° alignment measure counts both as aligned: the bump's slope stays below 30°).
TEST_CASE("rotation: the surface flattening removes a bump the paper's Eq. 1 keeps", "[rotation]") {
  TetMesh box = box_mesh(12, 12, 4, 0.25);  // [0,3]^2 x [0,1]
  const double h = 0.3;
  for (int v = 0; v < box.V.rows(); ++v) {
    const double dx = box.V(v, 0) - 1.5, dy = box.V(v, 1) - 1.5;
    box.V(v, 2) *= 1 + h * std::exp(-(dx * dx + dy * dy) / 0.25);  // bump of height h, width ~1 (4 tets)
  }
  auto bump_height = [](const TetMesh& m) {  // top-face height range: max - min of z over the top vertices
    double lo = 1e9, hi = -1e9;
    for (int v = 0; v < m.V.rows(); ++v)
      if (v >= 13 * 13 * 4) {  // z index 4: the top layer in box_mesh's vertex order
        lo = std::min(lo, m.V(v, 2));
        hi = std::max(hi, m.V(v, 2));
      }
    return hi - lo;
  };
  const double height0 = bump_height(box);
  REQUIRE(height0 == Approx(h).epsilon(0.01));
  RotationDeformParams paper, flat;  // flat: the default β
  paper.flatten = 0;
  const auto rp = rotation_deform(box, paper);
  const auto rf = rotation_deform(box, flat);
  INFO("bump height: input " << height0 << ", paper " << bump_height(rp.mesh) << ", flattened "
                             << bump_height(rf.mesh));
  CHECK(bump_height(rf.mesh) < 0.25 * height0);
  CHECK(bump_height(rp.mesh) > 0.5 * height0);
  CHECK(rf.iterations.back().alignment > 0.95);
  // The flattening fades out with the normal's deviation from its axis: with no flattening beyond 5°,
  // the bump's flanks (up to 27° steep) keep most of their height, as in the paper's Eq. 1.
  RotationDeformParams narrow;
  narrow.flatten_full_angle = 0;
  narrow.flatten_max_angle = 5;
  const auto rn = rotation_deform(box, narrow);
  INFO("narrow: " << bump_height(rn.mesh));
  CHECK(bump_height(rn.mesh) > 0.5 * height0);
  for (auto* r : {&rp, &rf}) {
    CHECK(r->iterations.back().inverted_tets == 0);
    CHECK(r->factor_stats.factorizations == 2);
  }
}

// On a generated bumpy torus, flattening raises the alignment reached after 5 iterations, every
// iteration, with few inverted tets (on the real models it even lowers their count, see rotation_deform.h).
TEST_CASE("rotation: flattening raises the alignment of a bumpy torus", "[rotation]") {
  const TetMesh tets = shape_tets("bumpy_torus", 48, 0.04);
  RotationDeformParams paper, flat;
  paper.flatten = 0;
  const auto rp = rotation_deform(tets, paper);
  const auto rf = rotation_deform(tets, flat);
  INFO("alignment paper " << rp.iterations.back().alignment << ", flattened " << rf.iterations.back().alignment
                          << "; inverted " << rp.iterations.back().inverted_tets << " / "
                          << rf.iterations.back().inverted_tets);
  CHECK(rf.iterations.back().alignment > rp.iterations.back().alignment + 0.05);
  CHECK(rf.iterations.back().inverted_tets < tets.T.rows() / 200);
  double prev = rf.input_alignment;
  for (auto& s : rf.iterations) {
    CHECK(s.alignment > prev);
    prev = s.alignment;
  }
}

TEST_CASE("rotation: multi-column and parallel solves give the same mesh", "[rotation]") {
  TetMesh box = box_mesh(4, 4, 3, 0.25);
  box.V = box.V * Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix().transpose();
  RotationDeformParams a, b;
  a.iterations = b.iterations = 3;
  b.solve_mode = SolveMode::Parallel;
  auto ra = rotation_deform(box, a), rb = rotation_deform(box, b);
  CHECK((ra.mesh.V - rb.mesh.V).cwiseAbs().maxCoeff() < 1e-10);
  CHECK(rb.factor_stats.solves == 3 * 7);
}

TEST_CASE("rotation: two disconnected boxes get one pin each", "[rotation]") {
  TetMesh a = box_mesh(3, 3, 3, 0.25), b = a;
  b.V.col(0).array() += 2.0;
  TetMesh two;
  two.V.resize(a.V.rows() * 2, 3);
  two.V << a.V, b.V;
  two.T.resize(a.T.rows() * 2, 4);
  two.T << a.T, (b.T.array() + static_cast<int>(a.V.rows())).matrix();
  RotationDeformParams p;
  p.iterations = 2;
  auto r = rotation_deform(two, p);
  CHECK(r.components == 2);
  CHECK((r.mesh.V - two.V).cwiseAbs().maxCoeff() < 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Failure paths

TEST_CASE("rotation: bad params and bad meshes are rejected with clear messages", "[rotation]") {
  const TetMesh box = box_mesh(2, 2, 2);
  RotationDeformParams p;
  SECTION("iterations out of range") {
    p.iterations = 0;
    CHECK_THROWS_AS(rotation_deform(box, p), ConfigError);
    CHECK_THROWS_WITH(rotation_deform(box, p), Catch::Contains("`iterations`") && Catch::Contains("[1, 50]"));
  }
  SECTION("anchor weight zero") {
    p.anchor_weight = 0;
    CHECK_THROWS_WITH(rotation_deform(box, p), Catch::Contains("`anchor_weight`") && Catch::Contains("(0, 1e6]"));
  }
  SECTION("feature angle") {
    p.feature_angle = 200;
    CHECK_THROWS_AS(rotation_deform(box, p), ConfigError);
  }
  SECTION("flatten") {
    p.flatten = 1.5;
    CHECK_THROWS_WITH(rotation_deform(box, p), Catch::Contains("`flatten`") && Catch::Contains("[0, 1]"));
    p.flatten = -0.1;
    CHECK_THROWS_AS(rotation_deform(box, p), ConfigError);
    p.flatten = 1;
    p.flatten_full_angle = 40;
    p.flatten_max_angle = 30;
    CHECK_THROWS_WITH(rotation_deform(box, p), Catch::Contains("`flatten_max_angle`"));
    p.flatten_full_angle = 95;
    CHECK_THROWS_WITH(rotation_deform(box, p), Catch::Contains("`flatten_full_angle`") && Catch::Contains("[0, 90]"));
  }
  SECTION("index out of range") {
    TetMesh m = box;
    m.T(3, 2) = 999;
    CHECK_THROWS_AS(rotation_deform(m, p), InvalidInput);
    CHECK_THROWS_WITH(rotation_deform(m, p), "box: tet 3 has vertex index 999 out of range (27 vertices)");
  }
  SECTION("unused vertex") {
    TetMesh m = box;
    m.V.conservativeResize(m.V.rows() + 1, 3);
    m.V.row(27) << 5, 5, 5;
    CHECK_THROWS_WITH(rotation_deform(m, p), "box: vertex 27 is used by no tet");
  }
  SECTION("empty and non-finite") {
    TetMesh m;
    m.source = "empty.mesh";
    CHECK_THROWS_WITH(rotation_deform(m, p), "empty.mesh: empty tet mesh (0 vertices, 0 tets)");
    TetMesh n = box;
    n.V(4, 1) = std::nan("");
    CHECK_THROWS_AS(rotation_deform(n, p), InvalidInput);
  }
}

// ---------------------------------------------------------------------------------------------
// Binding

TEST_CASE("rotation: node binding reports the metrics and saves iterations", "[rotation]") {
  const NodeSpec* spec = Registry::instance().find("rotation_deform/quaternion_laplace");
  REQUIRE(spec != nullptr);
  CHECK(Registry::instance().find("rotation_deform") == spec);
  CHECK(spec->output == "TetMesh");
  REQUIRE(spec->inputs.size() == 1);
  CHECK(spec->inputs[0].name == "tets");
  CHECK_THROWS_AS(spec->check_params(json{{"anchor_weight", -1.0}}, "rot"), ConfigError);
  CHECK_THROWS_AS(spec->check_params(json{{"iterations", 51}}, "rot"), ConfigError);
  CHECK_THROWS_AS(spec->check_params(json{{"solve_mode", "serial"}}, "rot"), ConfigError);

  TetMesh box = box_mesh(3, 3, 2, 0.5);
  box.V = box.V * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix().transpose();
  NodeContext ctx;
  ctx.id = "rot";
  ctx.type = spec->type;
  ctx.out_dir = std::filesystem::temp_directory_path() / "polyhex_rotation_test";
  std::filesystem::remove_all(ctx.out_dir);
  std::filesystem::create_directories(ctx.out_dir);
  const json params = spec->check_params(json{{"iterations", 3}, {"save_iterations", true}}, "rot");
  Inputs in;
  in.items.push_back(make_artefact(box));
  const Artefact out = spec->run(params, in, ctx);
  auto mesh = out.as<TetMesh>();
  CHECK(mesh->T.rows() == box.T.rows());
  const json& m = ctx.metrics;
  CHECK(m["iterations"] == 3);
  CHECK(m["factorizations"] == 2);
  CHECK(m["solves"] == 21);
  for (const char* key : {"alignment", "inverted_tets", "distortion", "distortion_max", "volume_ratio",
                          "min_quaternion_norm", "feature_vertices"})
    CHECK(m[key].size() == 3);
  for (const char* key : {"factor_seconds", "solve_seconds", "assemble_seconds", "compute_seconds"})
    CHECK(m[key].get<double>() >= 0);
  const auto saver = Registry::instance().saver("TetMesh");
  if (saver.second) {
    for (int k = 1; k <= 3; ++k)
      CHECK(std::filesystem::exists(ctx.out_dir / ("rot.iter" + std::to_string(k) + saver.first)));
  } else {
    WARN("no TetMesh saver registered; iteration files not checked");
  }
  std::filesystem::remove_all(ctx.out_dir);
}

// ---------------------------------------------------------------------------------------------
// Real models (../shared/data/surfaces), tets at edge length 0.04 of the bbox diagonal (the node
// default 0.02 takes minutes of TetGen time per model on 2 cores; figures at 0.02 are in the report).

namespace {

struct ModelRun {
  std::string name;
  RotationDeformResult result;
};

/// Runs every model once (cached across the [shared] test cases); empty when ../shared is missing.
const std::vector<ModelRun>& shared_model_runs() {
  static std::vector<ModelRun> runs = [] {
    std::vector<ModelRun> out;
    const auto dir = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces";
    if (!std::filesystem::exists(dir)) return out;
    for (const char* file :
         {"bunny.off", "fandisk.off", "rockerarm.obj", "fertility.off", "bumpy_torus.obj", "casting.off"}) {
      TetgenParams tp;
      tp.edge_length = 0.04;
      const TetMesh tets = tetrahedralize(read_surface(dir / file), tp);
      out.push_back({file, rotation_deform(tets, RotationDeformParams{})});
    }
    return out;
  }();
  return runs;
}

/// The model runs, or null (after a WARN) when ../shared is missing.
const std::vector<ModelRun>* shared_runs_or_skip() {
  const auto& runs = shared_model_runs();
  if (!runs.empty()) return &runs;
  WARN("../shared/data/surfaces not found: skipped");
  SUCCEED();
  return nullptr;
}

}  // namespace

TEST_CASE("rotation: real models gain alignment every iteration, no degenerate quaternion", "[rotation][shared]") {
  const auto* runs_or_null = shared_runs_or_skip();
  if (!runs_or_null) return;
  const auto& runs = *runs_or_null;
  for (const auto& run : runs) {
    INFO(run.name);
    const auto& r = run.result;
    double prev = r.input_alignment;
    for (const auto& s : r.iterations) {
      CHECK(s.alignment > prev);
      prev = s.alignment;
      CHECK(s.min_quaternion_norm > 0.1);
    }
    CHECK(r.factor_stats.factorizations == 2);
  }
}

// Issue 3: alignment >= 0.7 after 5 iterations on every model. The paper's Eq. 1 alone left bunny,
// fertility and bumpy_torus at 0.53-0.60; the surface flattening (default β) lifts them.
TEST_CASE("rotation: real models reach alignment 0.7 after 5 iterations", "[rotation][shared]") {
  const auto* runs_or_null = shared_runs_or_skip();
  if (!runs_or_null) return;
  const auto& runs = *runs_or_null;
  for (const auto& run : runs) {
    INFO(run.name << ": alignment " << run.result.iterations.back().alignment);
    CHECK(run.result.iterations.back().alignment >= 0.7);
  }
}
