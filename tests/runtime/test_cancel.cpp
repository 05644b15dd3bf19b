// Cooperative interruption (runtime/cancel.h): the flag, the signal handlers, and the safe points of
// the long stages (rotation_deform, polycube_segment, position_deform, hex_extract).
#include "nodes/hex_extract/hex_extract.h"
#include "nodes/polycube_segment/polycube_segment.h"
#include "nodes/position_deform/position_deform.h"
#include "nodes/rotation_deform/rotation_deform.h"
#include "nodes/tetrahedralize/tetgen.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "tests/helpers/voxel_maps.h"
#include "tests/helpers/voxel_shapes.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <memory>
#include <signal.h>
#include <thread>
#include <unistd.h>

using namespace polyhex;
using Catch::Matchers::Equals;

namespace {

/// Clears the flag when a test section ends, however it ends.
struct ClearInterrupt {
  ClearInterrupt() { clear_interrupt(); }
  ~ClearInterrupt() { clear_interrupt(); }
};

std::string interrupted_message() {
  try {
    throw_if_interrupted();
  } catch (const Interrupted& e) {
    return e.what();
  }
  return "";
}

/// Polls the flag for up to 2 s (the watcher thread sets it asynchronously).
bool wait_for_interrupt() {
  for (int i = 0; i < 2000 && !interrupted(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return interrupted();
}

std::shared_ptr<const TetMesh> box_tets() {
  TetgenParams tp;
  tp.edge_length = 0.2;
  static auto tets = std::make_shared<const TetMesh>(tetrahedralize(test::voxel_surface(test::voxel_box(2, 1, 1)), tp));
  return tets;
}

}  // namespace

TEST_CASE("cancel: the flag, request and clear; Interrupted names the signal", "[robust]") {
  ClearInterrupt guard;
  CHECK_FALSE(interrupted());
  CHECK_NOTHROW(throw_if_interrupted());
  request_interrupt();
  CHECK(interrupted());
  CHECK_THROWS_AS(throw_if_interrupted(), Interrupted);
  CHECK_THAT(interrupted_message(), Equals("interrupted by SIGINT"));
  clear_interrupt();
  CHECK_FALSE(interrupted());
  CHECK_NOTHROW(throw_if_interrupted());
}

TEST_CASE("cancel: SIGINT and SIGTERM sent to the process set the flag", "[robust]") {
  ClearInterrupt guard;
  install_interrupt_handlers();
  install_interrupt_handlers();  // idempotent
  // both blocked in this thread now (a watcher thread takes them with sigwait)
  sigset_t mask;
  REQUIRE(pthread_sigmask(SIG_BLOCK, nullptr, &mask) == 0);
  CHECK(sigismember(&mask, SIGINT) == 1);
  CHECK(sigismember(&mask, SIGTERM) == 1);
  for (int sig : {SIGTERM, SIGINT}) {
    clear_interrupt();
    REQUIRE(::kill(::getpid(), sig) == 0);
    CHECK(wait_for_interrupt());
    CHECK_THAT(interrupted_message(), Equals(sig == SIGTERM ? "interrupted by SIGTERM" : "interrupted by SIGINT"));
  }
}

TEST_CASE("cancel: a library that installs its own SIGTERM handler for a while cannot take the signal", "[robust]") {
  // what METIS does during an ordering (GKlib gk_sigtrap): a handler that would longjmp
  ClearInterrupt guard;
  install_interrupt_handlers();
  struct sigaction trap {
  }, old{};
  trap.sa_handler = [](int) { std::abort(); };
  sigemptyset(&trap.sa_mask);
  REQUIRE(sigaction(SIGTERM, &trap, &old) == 0);
  REQUIRE(::kill(::getpid(), SIGTERM) == 0);
  const bool seen = wait_for_interrupt();
  sigaction(SIGTERM, &old, nullptr);
  CHECK(seen);
  CHECK_THAT(interrupted_message(), Equals("interrupted by SIGTERM"));
}

TEST_CASE("cancel: every long stage stops at a safe point once interrupted", "[robust]") {
  ClearInterrupt guard;
  auto tets = box_tets();
  REQUIRE(tets->T.rows() > 50);
  auto seg = std::make_shared<const PolyCubeSegmentation>(segment_polycube(*tets));
  REQUIRE(seg->valid);
  const PolyCubeMap map = test::identity_map(test::voxel_box(2, 1, 1), 2);

  request_interrupt();
  CHECK_THROWS_AS(rotation_deform(*tets, RotationDeformParams{}), Interrupted);
  CHECK_THROWS_AS(segment_polycube(*tets), Interrupted);
  CHECK_THROWS_AS(position_deform(tets, *tets, seg, PositionDeformParams{}), Interrupted);
  CHECK_THROWS_AS(extract_hexes(map), Interrupted);

  // the flag cleared, the same calls run to the end
  clear_interrupt();
  CHECK(rotation_deform(*tets, RotationDeformParams{}).iterations.size() == size_t(RotationDeformParams{}.iterations));
  CHECK(extract_hexes(map).H.rows() == 2 * 8);
}

TEST_CASE("cancel: rotation_deform stops at the next iteration after an interrupt", "[robust]") {
  ClearInterrupt guard;
  auto tets = box_tets();
  RotationDeformParams p;
  p.iterations = 6;
  int calls = 0;
  IterationCallback cb = [&](int k, const TetMesh&, const RotationIterationStats&) {
    ++calls;
    if (k == 2) request_interrupt();  // as a signal arriving during iteration 2 would
  };
  CHECK_THROWS_AS(rotation_deform(*tets, p, cb), Interrupted);
  CHECK(calls == 2);
}
