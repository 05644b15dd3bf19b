// Stats declared once (runtime/stat_fields.h, graph/stat_metrics.h): merges by the declared rules, and
// the metrics export of every declared field under its declared name.
#include "graph/stat_metrics.h"
#include "runtime/stat_fields.h"

#include <catch2/catch.hpp>

#include <set>
#include <string>
#include <vector>

namespace polyhex {
namespace {

struct Inner {
  long count = 0;
  bool hit = false;
  static constexpr auto fields() {
    return std::make_tuple(stat("inner_count", &Inner::count, Combine::sum),
                           stat("inner_hit", &Inner::hit, Combine::any));
  }
};

struct Step {
  double value = 0;
  int n = 0;
  static constexpr auto fields() { return std::make_tuple(stat("value", &Step::value), stat("step_n", &Step::n)); }
};

struct Outer {
  int total = 0;
  double worst = 0, best = 1;
  int once = 0;
  double phase_a = 0, phase_b = 0;
  Inner inner;
  std::vector<Step> steps;
  static constexpr auto fields() {
    return std::make_tuple(stat("total", &Outer::total, Combine::sum), stat("worst", &Outer::worst, Combine::max),
                           stat("best", &Outer::best, Combine::min), stat("once", &Outer::once),
                           stat("phases.a", &Outer::phase_a, Combine::sum),
                           stat("phases.b", &Outer::phase_b, Combine::sum), stat("inner", &Outer::inner),
                           stat("steps", &Outer::steps));
  }
};

TEST_CASE("merge_stats combines each field by its declared rule, nested stats too", "[stats]") {
  Outer a, b;
  a.total = 2, a.worst = 0.5, a.best = 0.4, a.once = 7, a.phase_a = 1.5, a.inner.count = 3;
  b.total = 5, b.worst = 0.25, b.best = 0.1, b.once = 9, b.phase_a = 2.0, b.inner.count = 4, b.inner.hit = true;
  merge_stats(a, b);
  CHECK(a.total == 7);
  CHECK(a.worst == 0.5);
  CHECK(a.best == 0.1);
  CHECK(a.once == 7);  // keep: set once by the whole computation
  CHECK(a.phase_a == 3.5);
  CHECK(a.inner.count == 7);
  CHECK(a.inner.hit);
  merge_stats(a, Outer{});  // merging default figures changes nothing (the min keeps 0.1 against the default 1)
  CHECK(a.total == 7);
  CHECK(a.best == 0.1);
  CHECK(a.inner.hit);
}

TEST_CASE("put_stats writes every declared field under its name: nested flat, dotted as objects, vectors as arrays",
          "[stats]") {
  Outer s;
  s.total = 3, s.worst = 0.75, s.phase_b = 2.5, s.inner.count = 11, s.inner.hit = true;
  s.steps = {{0.5, 1}, {0.25, 2}, {0.125, 3}};
  nlohmann::json j;
  put_stats(s, j);
  CHECK(j["total"] == 3);
  CHECK(j["worst"] == 0.75);
  CHECK(j["phases"]["b"] == 2.5);
  CHECK(j["phases"]["a"] == 0.0);
  CHECK(j["inner_count"] == 11);
  CHECK(j["inner_hit"] == true);
  CHECK(!j.contains("inner"));
  CHECK(!j.contains("steps"));
  CHECK(j["value"] == nlohmann::json({0.5, 0.25, 0.125}));
  CHECK(j["step_n"] == nlohmann::json({1, 2, 3}));
  // 4 plain fields, one object with 2 members, 2 nested, 2 arrays: nothing lost, nothing extra
  CHECK(j.size() == 4 + 1 + 2 + 2);
}

}  // namespace
}  // namespace polyhex
