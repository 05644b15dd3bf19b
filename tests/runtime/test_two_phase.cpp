// [two-phase] parallel_two_phase: every job's two phases run once each, the second after the first, and an
// exception from a phase reaches the caller.
#include "runtime/two_phase.h"

#include <catch2/catch.hpp>
#include <tbb/task_arena.h>

#include <atomic>
#include <stdexcept>
#include <vector>

using namespace polyhex;

TEST_CASE("two phases: each phase once per job, the second after the first, on 1, 2 and 4 threads", "[two-phase]") {
  for (int threads : {1, 2, 4})
    for (int n : {0, 1, 3, 17}) {
      INFO(threads << " threads, " << n << " jobs");
      std::vector<std::atomic<int>> first(static_cast<size_t>(n)), second(static_cast<size_t>(n));
      std::atomic<int> order_errors{0};
      tbb::task_arena(threads).execute([&] {
        parallel_two_phase(
            n, [&](int i) { ++first[size_t(i)]; },
            [&](int i) {
              if (first[size_t(i)] != 1) ++order_errors;
              ++second[size_t(i)];
            });
      });
      for (int i = 0; i < n; ++i) {
        CHECK(first[size_t(i)] == 1);
        CHECK(second[size_t(i)] == 1);
      }
      CHECK(order_errors == 0);
    }
}

TEST_CASE("two phases: an exception from a first phase reaches the caller and skips that job's second", "[two-phase]") {
  std::atomic<int> second_of_failed{0};
  tbb::task_arena(2).execute([&] {
    CHECK_THROWS_AS(parallel_two_phase(
                        3,
                        [&](int i) {
                          if (i == 1) throw std::runtime_error("job 1");
                        },
                        [&](int i) { second_of_failed += i == 1; }),
                    std::runtime_error);
  });
  CHECK(second_of_failed == 0);
}
