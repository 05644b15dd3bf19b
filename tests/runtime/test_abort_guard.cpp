// [abort-guard] returns_without_abort: a call that aborts is left, the process goes on, and the guard works
// again; a call that returns or throws is as without the guard; guards in two threads at once.
#include "runtime/abort_guard.h"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <stdexcept>
#include <thread>

using polyhex::returns_without_abort;

TEST_CASE("abort guard: an abort() inside leaves the call, a return or an exception passes", "[abort-guard]") {
  int after = 0;
  CHECK(returns_without_abort([&] { ++after; }));
  CHECK(after == 1);
  for (int k = 0; k < 3; ++k) {  // again and again: the handler and the signal mask are as before
    volatile int reached = 0;
    CHECK_FALSE(returns_without_abort([&] {
      reached = 1;
      std::abort();
    }));
    CHECK(reached == 1);
  }
  CHECK_THROWS_AS(returns_without_abort([] { throw std::runtime_error("passes"); }), std::runtime_error);
  CHECK(returns_without_abort([&] { ++after; }));  // a guard after an exception works
  CHECK(after == 2);
}

TEST_CASE("abort guard: two threads abort inside their own guards at once", "[abort-guard]") {
  bool a = true, b = true;
  std::thread t1([&] { a = returns_without_abort([] { std::abort(); }); });
  std::thread t2([&] { b = returns_without_abort([] { std::abort(); }); });
  t1.join();
  t2.join();
  CHECK_FALSE(a);
  CHECK_FALSE(b);
}
