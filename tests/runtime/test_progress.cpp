// The terminal progress bar and the -v lines of `polyhex run` (runtime/progress.h).
#include "runtime/progress.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

/// What a ProgressPrinter in `mode` writes for the events `f` sends it (the printer destroyed at the end).
template <class F>
std::string printed(ProgressMode mode, int width, F f) {
  char* buf = nullptr;
  size_t len = 0;
  std::FILE* out = open_memstream(&buf, &len);
  REQUIRE(out);
  {
    ProgressPrinter p(out, mode, width);
    f(p);
  }
  std::fclose(out);
  std::string s(buf, len);
  std::free(buf);
  return s;
}

}  // namespace

TEST_CASE("progress: the bar's line", "[progress]") {
  CHECK(progress_bar_line("polycube", 0.42, "untangle", 200) == "[polycube] ########------------  42% untangle");
  CHECK(progress_bar_line("a", 0, "", 200, 4) == "[a] ----   0%");
  CHECK(progress_bar_line("a", 1, "x", 200, 4) == "[a] #### 100% x");
  CHECK(progress_bar_line("a", 0.999, "", 200, 10) == "[a] #########-  99%");  // rounded down: 100 % means done
  CHECK(progress_bar_line("a", 1.7, "", 200, 4) == "[a] #### 100%");
  CHECK(progress_bar_line("a", -3, "", 200, 4) == "[a] ----   0%");
  CHECK(progress_bar_line("a", std::nan(""), "", 200, 4) == "[a] ----   0%");
  // cut to the terminal's width, never wrapped
  const std::string cut = progress_bar_line("rotate", 0.5, "iteration 3 of 5, a long description", 30);
  CHECK(cut.size() == 30);
  CHECK(cut == "[rotate] ##########---------- ");
}

TEST_CASE("progress: the mode follows the terminal and -v", "[progress]") {
  CHECK(progress_mode(0, true) == ProgressMode::bar);
  CHECK(progress_mode(0, false) == ProgressMode::quiet);
  CHECK(progress_mode(1, false) == ProgressMode::lines);
  CHECK(progress_mode(2, true) == ProgressMode::lines);
}

TEST_CASE("progress: on a terminal one line updates in place; a node's end is a line of its own", "[progress]") {
  const std::string s = printed(ProgressMode::bar, 60, [](ProgressPrinter& p) {
    p.event("start", "rotate", "rotation_deform/quaternion_laplace", 0, "");
    p.event("progress", "rotate", "rotation_deform/quaternion_laplace", 0.5, "iteration 2");
    p.event("done", "rotate", "rotation_deform/quaternion_laplace", 1.25, "");
    p.event("progress", "polycube", "position_deform/chart_planes", 0.2, "poisson");
  });
  const std::string erase = "\r\033[K";
  CHECK(s == erase + "[rotate] --------------------   0% started" +  // start: forced
                 erase +  // the progress event within 50 ms of the start is not drawn; done erases the bar
                 "polyhex: rotate           rotation_deform/quaternion_laplace done in 1.25 s\n" + erase +
                 "[polycube] ####----------------  20% poisson" + erase);  // drawn on an empty line, erased at the end
  CHECK(s.find("\n[") == std::string::npos);                               // no bar ever ends a line
}

TEST_CASE("progress: redraws only when the line changes, at most every 50 ms", "[progress]") {
  const std::string s = printed(ProgressMode::bar, 80, [](ProgressPrinter& p) {
    p.event("start", "opt", "optimize/sj", 0, "");
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    p.event("progress", "opt", "optimize/sj", 0.301, "shape");
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    p.event("progress", "opt", "optimize/sj", 0.309, "shape");  // the same text: not drawn again
    for (int k = 0; k < 100; ++k) p.event("progress", "opt", "optimize/sj", 0.4 + k * 0.005, "maxmin");  // within 50 ms
    p.event("progress", "opt", "optimize/sj", 1.0, "maxmin");  // 100 %: always drawn
  });
  auto count = [&](const std::string& what) {
    size_t n = 0;
    for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
    return n;
  };
  CHECK(count(" 30% shape") == 1);
  CHECK(count("maxmin") <= 2);  // at most one of the fast ones, and the 100 %
  CHECK_THAT(s, Contains("[opt] #################### 100% maxmin"));
}

TEST_CASE("progress: -v prints every event as a line; quiet prints nothing", "[progress]") {
  auto events = [](ProgressPrinter& p) {
    p.event("start", "tets", "tetrahedralize/tetgen", 0, "");
    p.event("progress", "tets", "tetrahedralize/tetgen", 0.5, "half");
    p.event("cached", "hex", "hex_extract/lattice", 0.01, "");
    p.event("done", "tets", "tetrahedralize/tetgen", 2, "");
  };
  CHECK(printed(ProgressMode::lines, 80, events) ==
        "polyhex: tets             tetrahedralize/tetgen              started\n"
        "polyhex: tets              50% half\n"
        "polyhex: hex              hex_extract/lattice                loaded from cache in 0.01 s\n"
        "polyhex: tets             tetrahedralize/tetgen              done in 2.00 s\n");
  CHECK(printed(ProgressMode::quiet, 80, events).empty());
}
