// [placement] the canonical frame of placement.h: a surface and its turned, moved copies get the same
// positions bit for bit; the frame is a rotation with a power-of-two grid; bad input is refused. And the
// rigid frames of frames.h compose and invert.
#include "nodes/algorithms/shapes.h"
#include "nodes/orient/orient.h"
#include "nodes/orient/placement.h"
#include "runtime/errors.h"
#include "tests/helpers/rotations.h"

#include <catch2/catch.hpp>

#include <cmath>

using namespace polyhex;

namespace {

PlacementParams canonical() {
  PlacementParams p;
  p.frame = PlacementFrame::canonical;
  return p;
}

}  // namespace

TEST_CASE("placement: turned and moved copies of a surface get the same canonical positions, bit for bit",
          "[placement]") {
  for (const std::string name : {"bumpy_torus", "l_block", "fandisk_like"}) {
    const SurfaceMesh s = make_shape({name, 32});
    PlacementStats st;
    const Frames f = placement_frame(s, canonical(), &st);
    REQUIRE(f.candidates.size() == 1);
    const FrameCandidate& c = f.candidates[0];
    CHECK(c.branch == 1);
    CHECK(c.source == "canonical");
    CHECK((c.R * c.R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-14);
    CHECK(c.R.determinant() > 0);
    // the grid: a power of two, 2^-24 of the radius within a factor 2
    int e = 0;
    CHECK(std::frexp(c.grid, &e) == 0.5);
    CHECK(c.grid <= std::ldexp(st.radius, -24));
    CHECK(c.grid > std::ldexp(st.radius, -25));
    const RowMatrixX3d placed = c.place(s.V);
    // the canonical positions are the surface's, turned and moved: within the grid of R (x - centre)
    CHECK((placed - c.frame().apply(s.V)).cwiseAbs().maxCoeff() <= 0.5 * c.grid);
    long differ = 0;
    for (unsigned seed = 1; seed <= 6; ++seed) {
      const Eigen::Vector3d t = 10.0 * test::seeded_rotation(seed + 100).col(0) * double(seed);
      const SurfaceMesh copy = test::moved(s, test::seeded_rotation(seed), t);
      const Frames g = placement_frame(copy, canonical());
      CHECK(g.candidates[0].grid == c.grid);
      differ += (g.candidates[0].place(copy.V).array() != placed.array()).count();
    }
    INFO(name);
    CHECK(differ == 0);
  }
}

TEST_CASE("placement: the input frame is the identity; a flat or degenerate surface is refused", "[placement]") {
  const SurfaceMesh s = make_shape({"l_block", 16});
  const Frames f = placement_frame(s, PlacementParams{});
  REQUIRE(f.candidates.size() == 1);
  CHECK(f.candidates[0].frame().is_identity());
  CHECK(f.candidates[0].grid == 0);
  CHECK(f.candidates[0].place(s.V) == s.V);

  SurfaceMesh line = s;
  for (Eigen::Index i = 0; i < line.V.rows(); ++i) line.V.row(i) << double(i), 2.0 * double(i), 0.5;
  CHECK_THROWS_AS(placement_frame(line, canonical()), InvalidInput);
  SurfaceMesh bad = s;
  bad.V(3, 1) = std::nan("");
  CHECK_THROWS_AS(placement_frame(bad, canonical()), InvalidInput);
  PlacementParams coarse = canonical();
  coarse.grid_bits = 7;
  CHECK_THROWS_AS(placement_frame(s, coarse), ConfigError);
}

TEST_CASE("rigid frames: one then another is their composition, and the inverse takes positions back", "[placement]") {
  const RigidFrame a{test::seeded_rotation(3), Eigen::Vector3d(1.5, -2, 0.25)};
  const RigidFrame b{test::seeded_rotation(4), Eigen::Vector3d(-0.5, 3, 7)};
  RowMatrixX3d X(50, 3);
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    X.row(i) << std::sin(double(i)), std::cos(3.0 * double(i)), 0.1 * double(i);
  CHECK((a.then(b).apply(X) - b.apply(a.apply(X))).cwiseAbs().maxCoeff() < 1e-13);
  CHECK((a.inverse().apply(a.apply(X)) - X).cwiseAbs().maxCoeff() < 1e-13);
  CHECK((a.then(a.inverse()).apply(X) - X).cwiseAbs().maxCoeff() < 1e-13);
  CHECK(RigidFrame{}.is_identity());
  CHECK(!a.is_identity());
}

TEST_CASE("orient: on a canonical surface the input's axes run only where no minimum is near them",
          "[placement][orient]") {
  // An L-block (axis-aligned): its own axes are a minimum of the alignment energy, found by the search in
  // the canonical frame of any copy, which runs in their place; a bumpy torus: its axes and a turned copy's
  // are frames nearly as good as the best (energies near 1), which would run beside it by the default rule.
  // Either way every copy runs the same rotations.
  for (const std::string name : {"l_block", "bumpy_torus"}) {
    INFO(name);
    const SurfaceMesh s = make_shape({name, 32});
    std::vector<Frames> runs;
    for (unsigned seed : {0u, 9u, 10u, 11u}) {
      const SurfaceMesh in = seed == 0 ? s : test::moved(s, test::seeded_rotation(seed), Eigen::Vector3d(3, 1, -2));
      const FrameCandidate c = placement_frame(in, canonical()).candidates[0];
      SurfaceMesh placed = in;
      placed.V = c.place(in.V);
      const Eigen::Matrix3d axes = c.R.transpose();
      runs.push_back(orient_frames(placed, OrientParams{}, nullptr, &axes));
      CHECK(runs.back().candidates[0].source == "input");
      CHECK(runs.back().candidates[0].branch == 0);
    }
    if (name == "bumpy_torus") {  // the case the rule is for: some copy's axes within `within` of the best
      int near_best = 0;
      for (const Frames& f : runs)
        near_best += f.candidates[0].energy <= f.of_branch(1)->energy * (1 + OrientParams{}.within) + 1e-4;
      CHECK(near_best > 0);
    }
    for (size_t k = 1; k < runs.size(); ++k)
      for (int b = 1; b <= 3; ++b) {
        const FrameCandidate* x = runs[0].of_branch(b);
        const FrameCandidate* y = runs[k].of_branch(b);
        REQUIRE((x == nullptr) == (y == nullptr));
        if (x) CHECK(x->R == y->R);
      }
    REQUIRE(runs[0].of_branch(1) != nullptr);
    if (name == "l_block") {
      // the frame that runs first is the block's own (each row of its turn from the input's axes along an axis)
      const Eigen::Matrix3d M = runs[0].of_branch(1)->R * runs[0].candidates[0].R.transpose();
      for (int i = 0; i < 3; ++i) CHECK(M.row(i).cwiseAbs().maxCoeff() > std::cos(M_PI / 180));
    }
  }
}
