/// @file two_phase.h
/// @brief n jobs of two phases each (the second of job i needs the first of job i) on the task arena's
/// threads, every first phase started before any second: a few long jobs on fewer cores finish in about
/// (total work) / cores instead of whole jobs queued behind each other.
///
/// Three PolyCube axes on two cores, each a Poisson solve then a final solve: as whole jobs, one core runs
/// two axes one after the other (2 axes' time); as phases, the first core to be free starts the third
/// axis's Poisson solve and the second phases fill in behind (about 1.5 axes' time).
#pragma once

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <deque>
#include <mutex>

namespace polyhex {

/// Runs first(i) for every i in [0, n), and second(i) after first(i) has returned, in parallel. The first
/// phases are claimed in index order; a second phase is run by whichever worker is free, in the order the
/// first phases ended. Each call must write only its own job's outputs: which thread runs what varies, the
/// results do not. An exception from a phase propagates (the job's second phase is not run).
/// \pre first and second are callable with an int and safe to run concurrently for different jobs
template <class First, class Second>
void parallel_two_phase(int n, First first, Second second) {
  std::atomic<int> next{0};
  std::mutex mutex;
  std::deque<int> ready;  // jobs whose first phase has ended
  const int workers = std::max(1, std::min(n, tbb::this_task_arena::max_concurrency()));
  tbb::parallel_for(0, workers, [&](int) {
    for (;;) {
      const int i = next.fetch_add(1);
      if (i < n) {
        first(i);
        const std::lock_guard<std::mutex> lock(mutex);
        ready.push_back(i);
        continue;
      }
      int j;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        if (ready.empty()) return;  // the jobs still in their first phase run their second themselves
        j = ready.front();
        ready.pop_front();
      }
      second(j);
    }
  });
}

}  // namespace polyhex
