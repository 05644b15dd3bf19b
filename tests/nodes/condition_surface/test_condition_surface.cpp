// Surface conditioning: diagnosis counts on generated defective surfaces, each repair, the
// refusals, pass-through bit for bit, the remesh to size, and the whole pipeline on every kind of
// defective input (no inverted hex).
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/condition_surface/condition_surface.h"
#include "nodes/condition_surface/surface_ops.h"
#include "nodes/formats/surface_io.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "runtime/errors.h"
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <map>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

// Two surfaces as one triangle set (vertices not shared).
SurfaceMesh merge(const SurfaceMesh& a, const SurfaceMesh& b) {
  SurfaceMesh m;
  m.source = "merged";
  m.V.resize(a.V.rows() + b.V.rows(), 3);
  m.V << a.V, b.V;
  m.F.resize(a.F.rows() + b.F.rows(), 3);
  m.F << a.F, (b.F.array() + int(a.V.rows())).matrix();
  return m;
}

// The built-in box (1 x 0.6 x 0.4, n cells along x) scaled to [lo, lo + size] and rounded to a grid
// of 2^-20, so that boxes built side by side share their touching vertices exactly.
SurfaceMesh box_at(const Eigen::RowVector3d& lo, const Eigen::RowVector3d& size, int n) {
  SurfaceMesh b = make_shape(ShapeParams{"box", n});
  const Eigen::RowVector3d mn = b.V.colwise().minCoeff(), mx = b.V.colwise().maxCoeff();
  for (Eigen::Index v = 0; v < b.V.rows(); ++v) {
    const Eigen::RowVector3d t = (b.V.row(v) - mn).cwiseQuotient(mx - mn);
    b.V.row(v) = ((lo + t.cwiseProduct(size)) * 1048576.0).array().round() / 1048576.0;
  }
  return b;
}

// One vertex per position (what a file that shares them holds).
SurfaceMesh welded(SurfaceMesh m) {
  std::map<std::array<double, 3>, int> index;
  std::vector<int> map(size_t(m.V.rows()));
  std::vector<Eigen::RowVector3d> V;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const auto [it, added] = index.emplace(std::array<double, 3>{m.V(v, 0), m.V(v, 1), m.V(v, 2)}, int(V.size()));
    if (added) V.push_back(m.V.row(v));
    map[size_t(v)] = it->second;
  }
  m.V.resize(Eigen::Index(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(Eigen::Index(i)) = V[i];
  for (Eigen::Index i = 0; i < m.F.size(); ++i) m.F.data()[i] = map[size_t(m.F.data()[i])];
  return m;
}

// Two boxes that share a corner vertex, or an edge.
SurfaceMesh pinched_boxes() { return welded(merge(box_at({0, 0, 0}, {1, 1, 1}, 4), box_at({1, 1, 1}, {1, 1, 1}, 4))); }
SurfaceMesh edge_boxes() { return welded(merge(box_at({0, 0, 0}, {1, 1, 1}, 4), box_at({1, 1, 0}, {1, 1, 1}, 4))); }

SurfaceMesh sphere(int res, double shift = 0) {
  SurfaceMesh s = make_shape(ShapeParams{"sphere", res});
  s.V.col(0).array() += shift;
  return s;
}

// Removes `seed` and the triangles sharing a vertex with it: a hole a few triangles wide.
SurfaceMesh punch(const SurfaceMesh& s, const std::vector<int>& seeds) {
  std::vector<char> drop(size_t(s.F.rows()), 0);
  for (int seed : seeds)
    for (Eigen::Index f = 0; f < s.F.rows(); ++f)
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j) drop[size_t(f)] |= s.F(f, k) == s.F(seed, j);
  SurfaceMesh out = s;
  Eigen::Index n = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    if (!drop[size_t(f)]) out.F.row(n++) = s.F.row(f);
  out.F.conservativeResize(n, 3);
  return out;
}

// A box as a triangle soup: every triangle with its own vertices, every seventh one duplicated and
// every third flipped.
SurfaceMesh soup_box() {
  const SurfaceMesh b = make_shape(ShapeParams{"box", 12});
  SurfaceMesh s;
  s.source = "soup";
  std::vector<Eigen::RowVector3d> V;
  std::vector<Eigen::RowVector3i> F;
  for (Eigen::Index f = 0; f < b.F.rows(); ++f) {
    const int copies = f % 7 == 0 ? 2 : 1;
    for (int c = 0; c < copies; ++c) {
      const int base = int(V.size());
      for (int k = 0; k < 3; ++k) V.push_back(b.V.row(b.F(f, k)));
      F.push_back((f + c) % 3 == 0 ? Eigen::RowVector3i(base, base + 2, base + 1)
                                   : Eigen::RowVector3i(base, base + 1, base + 2));
    }
  }
  s.V.resize(Eigen::Index(V.size()), 3);
  for (size_t i = 0; i < V.size(); ++i) s.V.row(Eigen::Index(i)) = V[i];
  s.F.resize(Eigen::Index(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) s.F.row(Eigen::Index(i)) = F[i];
  return s;
}

double diagonal(const SurfaceMesh& s) { return (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).norm(); }

SurfaceDiagnosis diagnose(const SurfaceMesh& s, const ConditionParams& p = {}) {
  const double d = diagonal(s);
  return diagnose_surface(s, p.hex_edge_length * d, p.edge_length * d);
}

// The closed, manifold check of the reader (and of TetGen's input).
bool clean(SurfaceMesh s) {
  SurfaceReadReport r;
  try {
    check_and_repair_surface(s, "t", r);
    return count_self_intersections(s) == 0;
  } catch (const InvalidInput&) {
    return false;
  }
}

}  // namespace

TEST_CASE("diagnosis: the defects of generated surfaces, counted", "[condition]") {
  SECTION("a clean box: no defect, tessellation ratio from the triangle size") {
    const SurfaceMesh b = box_at({0, 0, 0}, {1, 1, 1}, 8);
    const SurfaceDiagnosis d = diagnose(b);
    CHECK(d.defects().empty());
    CHECK(d.components == 1);
    CHECK(d.volume == Approx(1.0));
    // cells of 1/8 = 0.125 on a box of diagonal sqrt(3): tet edge 0.0346; right triangles of legs
    // 0.125 are coarser than the tet size: the ratio of a coarse input, sqrt(3/4)
    CHECK(d.tessellation_ratio == Approx(std::sqrt(0.75)).epsilon(0.01));
    // the same box 10 times finer than the tet edge (cells of 0.0035, altitude 0.0024): 14 times
    const SurfaceDiagnosis fine = diagnose(box_at({0, 0, 0}, {1, 1, 1}, 288));
    CHECK(fine.tessellation_ratio > 7);
    CHECK(fine.tessellation_ratio < 20);
  }
  SECTION("holes punched through a sphere") {
    const SurfaceMesh s = sphere(24);
    const SurfaceDiagnosis d = diagnose(punch(s, {0, int(s.F.rows() / 2), int(s.F.rows()) - 1}));
    CHECK(d.boundary_loops == 3);
    CHECK(d.nonmanifold_edges == 0);
    CHECK(d.longest_loop_edges >= 6);
    REQUIRE(d.defects().size() == 1);
    CHECK_THAT(d.defects()[0], Contains("3 open boundary loops"));
  }
  SECTION("two boxes touching at a corner: one pinch vertex") {
    const SurfaceMesh m = pinched_boxes();
    const SurfaceDiagnosis d = diagnose(m);
    CHECK(d.nonmanifold_vertices == 1);
    CHECK(d.nonmanifold_edges == 0);
    CHECK(d.boundary_edges == 0);
  }
  SECTION("two boxes sharing an edge: non-manifold edges along it") {
    const SurfaceMesh m = edge_boxes();
    const SurfaceDiagnosis d = diagnose(m);
    CHECK(d.nonmanifold_edges == 2);  // the shared edge: 2 segments (the box has 2 cells along z), each in 4 triangles
    CHECK(d.boundary_edges == 0);
  }
  SECTION("two overlapping spheres: self-intersecting pairs") {
    const SurfaceDiagnosis d = diagnose(merge(sphere(24), sphere(24, 0.5)));
    CHECK(d.self_intersections > 0);
    CHECK(d.components == 2);
    CHECK(d.boundary_edges == 0);
  }
  SECTION("a soup with duplicated and flipped triangles") {
    const SurfaceMesh soup = soup_box();
    const SurfaceMesh m = welded(soup);
    const SurfaceDiagnosis d = diagnose(m);
    long expected = 0;
    for (Eigen::Index f = 0; f < make_shape(ShapeParams{"box", 12}).F.rows(); ++f) expected += f % 7 == 0;
    CHECK(d.duplicate_faces == expected);
    CHECK(d.orientable);
    CHECK(d.boundary_edges == 0);
  }
  SECTION("degenerate triangles") {
    SurfaceMesh b = box_at({0, 0, 0}, {1, 1, 1}, 2);
    b.F(0, 1) = b.F(0, 0);  // repeated vertex
    CHECK(diagnose(b).degenerate_faces == 1);
  }
}

TEST_CASE("condition_surface: a clean input at the tet size passes through bit for bit", "[condition]") {
  const SurfaceMesh b = box_at({0, 0, 0}, {1, 1, 1}, 8);
  ConditionReport r;
  const SurfaceMesh out = condition_surface(b, SurfaceRepair::automatic, {}, r);
  CHECK(r.passed_through);
  CHECK(r.repair == "none");
  CHECK_FALSE(r.remeshed);
  CHECK(r.warnings.empty());
  CHECK(out.V == b.V);
  CHECK(out.F == b.F);
}

TEST_CASE("condition_surface: each repair leaves a clean surface close to the original", "[condition]") {
  ConditionParams p;
  auto check_repair = [&](const SurfaceMesh& in, SurfaceRepair variant, const std::string& expected_repair) {
    REQUIRE_FALSE(clean(in));
    ConditionReport r;
    const SurfaceMesh out = condition_surface(in, variant, p, r);
    CHECK(r.repair == expected_repair);
    CHECK_FALSE(r.passed_through);
    CHECK(clean(out));
    CHECK(r.output.defects().empty());
    // a level set or wrap strays at most max_deviation; a local fill is bounded by the hole's size
    if (expected_repair != "local") CHECK(r.deviation_to_original < p.max_deviation);
    REQUIRE(r.warnings.size() >= 1);
    CHECK_THAT(r.warnings.back(), Contains("repaired by") && Contains("hex edges of the original"));
    return r;
  };
  SECTION("holes: the local repair fills them and moves nothing else") {
    const SurfaceMesh s = sphere(24);
    const ConditionReport r =
        check_repair(punch(s, {0, int(s.F.rows() / 2), int(s.F.rows()) - 1}), SurfaceRepair::automatic, "local");
    CHECK(r.holes_filled == 3);
    CHECK(r.deviation_from_original < 1e-9);  // every original point is on the result
  }
  SECTION("a pinch vertex: split, the two boxes come apart") {
    const SurfaceMesh m = pinched_boxes();
    const ConditionReport r = check_repair(m, SurfaceRepair::automatic, "local");
    CHECK(r.pinches_split == 1);
    CHECK(r.output.components == 2);
  }
  SECTION("a non-manifold edge: the level set joins the two boxes") {
    const SurfaceMesh m = edge_boxes();
    const ConditionReport r = check_repair(m, SurfaceRepair::automatic, "levelset");
    CHECK(r.remeshed);
    CHECK(r.output.components == 1);
    CHECK(r.feature_edges > 0);  // the boxes' edges were kept sharp
  }
  SECTION("two overlapping spheres: their union") {
    const ConditionReport r = check_repair(merge(sphere(24), sphere(24, 0.5)), SurfaceRepair::levelset, "levelset");
    CHECK(r.output.components == 1);
    // the union's volume: two unit-diameter spheres at distance 0.5 (lens of 2 caps of height 0.25)
    const double r0 = 0.5, h = 0.25, lens = 2 * M_PI * h * h * (3 * r0 - h) / 3;
    const double expected = 2 * 4.0 / 3 * M_PI * r0 * r0 * r0 - lens;
    const double box = 1.5 * 1.0 * 1.0;
    CHECK(r.output.volume * box == Approx(expected).epsilon(0.03));
  }
  SECTION("a soup with duplicated and flipped triangles") {
    const ConditionReport r = check_repair(welded(soup_box()), SurfaceRepair::automatic, "local");
    CHECK(r.deviation_from_original < 1e-9);
  }
  SECTION("an open surface wrapped: a box without its top") {
    SurfaceMesh b = box_at({0, 0, 0}, {1, 1, 1}, 6);
    std::vector<int> top;
    for (Eigen::Index f = 0; f < b.F.rows(); ++f)
      if (b.V(b.F(f, 0), 2) > 0.999 && b.V(b.F(f, 1), 2) > 0.999 && b.V(b.F(f, 2), 2) > 0.999) top.push_back(int(f));
    SurfaceMesh open = b;
    Eigen::Index n = 0;
    for (Eigen::Index f = 0; f < b.F.rows(); ++f)
      if (std::find(top.begin(), top.end(), int(f)) == top.end()) open.F.row(n++) = b.F.row(f);
    open.F.conservativeResize(n, 3);
    // the top's hole is far longer than max_hole_perimeter: the local repair leaves it, so does the
    // wrap (its inside is open to the ball): both refused, naming what each left
    ConditionReport refused;
    REQUIRE_THROWS_WITH(condition_surface(open, SurfaceRepair::automatic, p, refused),
                        Contains("no repair leaves a clean surface") || Contains("thinner than a hex edge"));
    // with a larger hole bound, the local repair closes it
    ConditionParams big = p;
    big.max_hole_perimeter = 1000;
    ConditionReport r;
    const SurfaceMesh out = condition_surface(open, SurfaceRepair::automatic, big, r);
    CHECK(r.repair == "local");
    CHECK(clean(out));
  }
}

TEST_CASE("condition_surface: what cannot be repaired soundly is refused", "[condition]") {
  ConditionParams p;
  ConditionReport r;
  SECTION("a single triangle") {
    SurfaceMesh t;
    t.source = "tri.obj";
    t.V.resize(3, 3);
    t.V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    t.F.resize(1, 3);
    t.F << 0, 1, 2;
    REQUIRE_THROWS_AS(condition_surface(t, SurfaceRepair::automatic, p, r), InvalidInput);
    REQUIRE_THROWS_WITH(condition_surface(t, SurfaceRepair::automatic, p, r), Contains("tri.obj"));
    REQUIRE_THROWS_WITH(condition_surface(t, SurfaceRepair::alpha_wrap, p, r), Contains("thinner than a hex edge"));
  }
  SECTION("three faces of a tetrahedron") {
    SurfaceMesh t;
    t.source = "tet3.obj";
    t.V.resize(4, 3);
    t.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    t.F.resize(3, 3);
    t.F << 0, 2, 1, 0, 1, 3, 0, 3, 2;
    REQUIRE_THROWS_AS(condition_surface(t, SurfaceRepair::automatic, p, r), InvalidInput);
    REQUIRE_THROWS_WITH(condition_surface(t, SurfaceRepair::alpha_wrap, p, r), Contains("thinner than a hex edge"));
  }
  SECTION("policy strict refuses any defect, naming it") {
    ConditionParams strict = p;
    strict.policy = DefectPolicy::strict;
    const SurfaceMesh s = sphere(24);
    REQUIRE_THROWS_WITH(condition_surface(punch(s, {0}), SurfaceRepair::automatic, strict, r),
                        Contains("sphere: 1 open boundary loop") && Contains("refused by policy `strict`"));
    // a clean input passes under strict too
    CHECK_NOTHROW(condition_surface(s, SurfaceRepair::automatic, strict, r));
  }
  SECTION("a repair straying beyond max_deviation") {
    ConditionParams tight = p;
    tight.max_deviation = 0.01;  // the wrap's own offset is 0.1 hex edges
    REQUIRE_THROWS_WITH(condition_surface(merge(sphere(24), sphere(24, 0.5)), SurfaceRepair::alpha_wrap, tight, r),
                        Contains("more than max_deviation"));
  }
  SECTION("a local repair that cannot mend a non-manifold edge, as the only variant") {
    const SurfaceMesh m = edge_boxes();
    REQUIRE_THROWS_WITH(condition_surface(m, SurfaceRepair::local, p, r),
                        Contains("non-manifold edges") && Contains("condition_surface/auto tries more"));
  }
}

TEST_CASE("condition_surface: an over-tessellated input is remeshed so the tets follow the size", "[condition]") {
  ConditionParams p;
  p.edge_length = 0.04;
  p.hex_edge_length = 0.02;
  const SurfaceMesh fine = sphere(160);  // about 8 times finer than a tet edge of 0.04
  ConditionReport r;
  const SurfaceMesh out = condition_surface(fine, SurfaceRepair::automatic, p, r);
  CHECK(r.input.tessellation_ratio > 6);
  CHECK(r.remeshed);
  CHECK(r.repair == "none");
  CHECK(r.output.tessellation_ratio < 2);
  CHECK(r.deviation_to_original < 0.2);
  CHECK(r.deviation_from_original < 0.2);
  TetgenParams tp;
  tp.edge_length = p.edge_length;
  TetgenStats ts;
  tetrahedralize(out, tp, &ts);
  CHECK(ts.tets < 2 * ts.estimated_tets);
  // without the remesh the tets follow the input's triangles
  TetgenStats raw;
  tetrahedralize(fine, tp, &raw);
  CHECK(raw.tets > 3 * raw.estimated_tets);
}

TEST_CASE("quality against an open original: one-sided distances", "[condition][quality]") {
  // A hex cube against the closed box and against the box without its top face.
  HexMesh h;
  h.V.resize(8, 3);
  h.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  h.H.resize(1, 8);
  h.H << 0, 1, 2, 3, 4, 5, 6, 7;
  SurfaceMesh b = box_at({0, 0, 0}, {1, 1, 1}, 2);
  const HexQuality closed = hex_quality(h, &b);
  CHECK(closed.surface_closed);
  CHECK(closed.hausdorff_max < 1e-9);
  Eigen::Index n = 0;
  SurfaceMesh open = b;
  for (Eigen::Index f = 0; f < b.F.rows(); ++f)
    if (!(b.V(b.F(f, 0), 2) > 0.999 && b.V(b.F(f, 1), 2) > 0.999 && b.V(b.F(f, 2), 2) > 0.999))
      open.F.row(n++) = b.F.row(f);
  open.F.conservativeResize(n, 3);
  const HexQuality q = hex_quality(h, &open);
  CHECK_FALSE(q.surface_closed);
  CHECK(q.hausdorff_max < 1e-9);  // the open box lies on the cube; the cube's top has no surface to be near
  CHECK(q.volume_ratio == 0);
}

// The whole default pipeline on each kind of defective input, at a coarse size: no inverted hex, and
// the repair named in the report.
TEST_CASE("defective inputs mesh through the default pipeline with no inverted hex", "[condition][cli]") {
  polyhex::test::TempDir dir("defective");
  struct Case {
    std::string name;
    SurfaceMesh mesh;
    std::string repair;
  };
  const SurfaceMesh s = sphere(24);
  std::vector<Case> cases = {
      {"holes", punch(s, {0, int(s.F.rows() / 2), int(s.F.rows()) - 1}), "local"},
      {"pinch", pinched_boxes(), "local"},
      {"nonmanifold_edge", edge_boxes(), "levelset"},
      {"overlap", merge(sphere(24), sphere(24, 0.5)), "levelset"},
      {"soup", soup_box(), "local"},
      {"fine", sphere(200), "none"},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const auto in = dir / (c.name + ".obj");
    write_surface(c.mesh, in);
    const auto out = dir / c.name;
    const auto run = polyhex::test::run_polyhex("run " + std::string(POLYHEX_SOURCE_DIR) + "/configs/default.json -i " +
                                                in.string() + " --out " + out.string() +
                                                " --no-cache --set vars.tet_edge=0.04 --set vars.hex_edge=0.03");
    INFO(run.out);
    REQUIRE(run.code == 0);
    const auto report = nlohmann::json::parse(polyhex::test::read_text(out / "report.json"));
    const auto& cond = report["nodes"]["condition"];
    CHECK(cond["metrics"]["repair"] == c.repair);
    CHECK(cond["metrics"]["output"]["defects"].empty());
    if (c.repair != "none") CHECK_FALSE(cond["warnings"].empty());
    if (c.name == "fine") CHECK(cond["metrics"]["remeshed"] == true);
    const auto& q = report["nodes"]["quality"]["metrics"];
    CHECK(q["inverted"] == 0);
    CHECK(q["sj_min"].get<double>() > 0);
    // measured against the original as read (one-sided where it is open)
    CHECK(q["hausdorff_sides"] == (c.name == "holes" ? "surface_to_mesh" : "symmetric"));
  }
}

TEST_CASE("condition_surface on the shared models: girl.off repaired, the others as read", "[condition][shared]") {
  const std::filesystem::path dir = std::filesystem::path(POLYHEX_SHARED_DIR) / "data" / "surfaces";
  if (!std::filesystem::exists(dir)) {
    WARN("skipped: " << dir << " not found");
    SUCCEED();
    return;
  }
  SECTION("girl.off intersects itself: the alpha wrap mends what the level set cannot") {
    const SurfaceMesh girl = read_surface(dir / "girl.off");
    ConditionReport r;
    const SurfaceMesh out = condition_surface(girl, SurfaceRepair::automatic, {}, r);
    CHECK(r.input.self_intersections > 0);
    CHECK(r.repair == "alpha_wrap");
    CHECK(r.remeshed);
    CHECK(clean(out));
    CHECK(r.deviation_to_original < 2.0);
  }
  SECTION("clean models pass through bit for bit") {
    for (const char* name : {"bunny.off", "fandisk.off", "7-connected.stl", "in-volume_twist.stl"}) {
      INFO(name);
      const SurfaceMesh s = read_surface(dir / name);
      ConditionReport r;
      const SurfaceMesh out = condition_surface(s, SurfaceRepair::automatic, {}, r);
      CHECK(r.passed_through);
      CHECK(out.V == s.V);
      CHECK(out.F == s.F);
    }
  }
}
