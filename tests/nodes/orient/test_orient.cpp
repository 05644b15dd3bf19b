// The orientation search (nodes/orient): the frame it finds for turned copies of generated shapes.
#include "nodes/algorithms/rotations.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/orient/orient.h"
#include "runtime/errors.h"
#include "tests/helpers/rotations.h"

#include <catch2/catch.hpp>

using namespace polyhex;

namespace {

/// The lowest-energy candidate other than the input frame.
const FrameCandidate& best_other(const Frames& f) {
  REQUIRE(f.candidates.size() >= 2);
  return f.candidates[1];
}

}  // namespace

TEST_CASE("orient: a turned box gets the box's own frame back, to within a degree", "[orient]") {
  const SurfaceMesh box = make_shape({"box", 16});
  CHECK(alignment_energy(box, Eigen::Matrix3d::Identity()) == Approx(0).margin(1e-12));
  for (unsigned seed : {11u, 12u, 13u, 14u, 15u}) {
    const Eigen::Matrix3d R = test::seeded_rotation(seed);
    const SurfaceMesh turned = test::rotated(box, R);
    const Frames f = orient_frames(turned, OrientParams{});
    REQUIRE(f.candidates[0].source == "input");
    CHECK(f.candidates[0].R == Eigen::Matrix3d::Identity());
    const FrameCandidate& c = best_other(f);
    INFO("seed " << seed << ": input energy " << f.candidates[0].energy << ", best " << c.energy << " from "
                 << c.source);
    CHECK(c.branch == 1);
    CHECK(f.candidates[0].branch == 0);  // the turned input frame is far worse: not run
    // x_frame = C x_turned = C R x_box: C R is one of the cube's rotations when C is the box's frame.
    CHECK(frame_distance_degrees(c.R, R.transpose()) < 1.0);
    CHECK(c.energy < 1e-8);
  }
}

TEST_CASE("orient: an axis-aligned part runs in its input frame alone", "[orient]") {
  for (const char* name : {"box", "l_block", "fandisk_like"}) {
    const Frames f = orient_frames(make_shape({name, 32}), OrientParams{});
    int running = 0;
    for (const FrameCandidate& c : f.candidates) running += c.branch > 0;
    INFO(name << ": input energy " << f.candidates[0].energy);
    CHECK(running == 1);
    CHECK(f.candidates[0].branch == 1);
  }
}

TEST_CASE("orient: a turned copy's best frame is as good as the original's", "[orient]") {
  for (const char* name : {"fandisk_like", "l_block", "rod_with_holes"}) {
    const SurfaceMesh s = make_shape({name, 32});
    const Frames original = orient_frames(s, OrientParams{});
    double e0 = original.candidates[0].energy;
    for (const FrameCandidate& c : original.candidates) e0 = std::min(e0, c.energy);
    for (unsigned seed : {21u, 22u, 23u}) {
      const Frames f = orient_frames(test::rotated(s, test::seeded_rotation(seed)), OrientParams{});
      INFO(name << " seed " << seed << ": original best " << e0 << ", turned input " << f.candidates[0].energy);
      CHECK(best_other(f).energy <= e0 + 1e-6);
      CHECK(best_other(f).branch == 1);
    }
  }
}

TEST_CASE(
    "orient: with flat_sigma_degrees, a turned part with flat and curved faces gets the flat faces' frame exactly",
    "[orient]") {
  // The quartic energy's minimum leans towards the rounded, curved and slanted faces' normals (here by
  // 0.04-0.23 degree); the flat faces' frame is the part's own, and the turned copy must come back to it.
  for (const char* name : {"l_block", "rod_with_holes", "fandisk_like"}) {
    const SurfaceMesh s = make_shape({name, 32});
    for (unsigned seed : {31u, 32u, 33u}) {
      const Eigen::Matrix3d R = test::seeded_rotation(seed);
      OrientParams on;
      on.flat_sigma_degrees = 3;
      OrientStats st;
      const Frames f = orient_frames(test::rotated(s, R), on, &st);
      const FrameCandidate& c = best_other(f);
      INFO(name << " seed " << seed << ": " << c.source << ", " << frame_distance_degrees(c.R, R.transpose())
                << " degrees from the part's frame");
      CHECK(st.flattened >= 1);
      CHECK(c.source.find("flat_faces") != std::string::npos);
      CHECK(frame_distance_degrees(c.R, R.transpose()) < 1e-3);
      // the energy's own minimum (the default)
      CHECK(frame_distance_degrees(best_other(orient_frames(test::rotated(s, R), OrientParams{})).R, R.transpose()) >
            1e-2);
    }
  }
}

TEST_CASE("orient: with flat_sigma_degrees, a smooth shape's minima are not moved (no flat faces)", "[orient]") {
  for (const char* name : {"sphere", "torus", "bumpy_torus", "bent_pipe"}) {
    const SurfaceMesh s = test::rotated(make_shape({name, 32}), test::seeded_rotation(41));
    OrientParams on;
    on.flat_sigma_degrees = 3;
    OrientStats st;
    const Frames with = orient_frames(s, on, &st);
    const Frames without = orient_frames(s, OrientParams{});
    INFO(name);
    CHECK(st.flattened == 0);
    REQUIRE(with.candidates.size() == without.candidates.size());
    for (size_t k = 0; k < with.candidates.size(); ++k) {
      CHECK(with.candidates[k].R == without.candidates[k].R);  // bit for bit
      CHECK(with.candidates[k].energy == without.candidates[k].energy);
      CHECK(with.candidates[k].branch == without.candidates[k].branch);
    }
  }
}

TEST_CASE("orient: limits of the search", "[orient]") {
  const SurfaceMesh s = test::rotated(make_shape({"l_block", 16}), test::seeded_rotation(5));
  OrientParams p;
  p.max_frames = 1;
  const Frames one = orient_frames(s, p);
  int running = 0;
  for (const FrameCandidate& c : one.candidates) running += c.branch > 0;
  CHECK(running == 1);
  CHECK(one.candidates[1].branch == 1);
  p.max_frames = 0;
  CHECK_THROWS_AS(orient_frames(s, p), ConfigError);
  OrientParams q;
  q.flat_sigma_degrees = 25;
  CHECK_THROWS_AS(orient_frames(s, q), ConfigError);
  q = OrientParams{};
  q.flat_min_area = 1.5;
  CHECK_THROWS_AS(orient_frames(s, q), ConfigError);
  SurfaceMesh flat;
  flat.V = RowMatrixX3d::Zero(3, 3);
  flat.F.resize(1, 3);
  flat.F << 0, 1, 2;
  CHECK_THROWS_AS(orient_frames(flat, OrientParams{}), InvalidInput);
  // Candidates other than the input are distinct up to the cube's symmetries.
  const Frames f = orient_frames(s, OrientParams{});
  for (size_t a = 1; a < f.candidates.size(); ++a)
    for (size_t b = a + 1; b < f.candidates.size(); ++b)
      CHECK(frame_distance_degrees(f.candidates[a].R, f.candidates[b].R) >= OrientParams{}.distinct_degrees);
}
