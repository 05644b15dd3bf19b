#include "runtime/memory.h"

#include <catch2/catch.hpp>

#include <vector>

using namespace polyhex;

TEST_CASE("process_memory: resident memory rises by what the process touches", "[memory]") {
  const ProcessMemory before = process_memory();
  REQUIRE(before.rss_mb > 0);
  REQUIRE(before.peak_rss_mb >= before.rss_mb);
  ProcessMemory during;
  {
    std::vector<char> block(size_t(256) << 20);  // 256 MiB, every page written
    for (size_t i = 0; i < block.size(); i += 4096) block[i] = char(i);
    during = process_memory();
    CHECK(during.rss_mb >= before.rss_mb + 240);
    CHECK(during.peak_rss_mb >= before.rss_mb + 240);
    CHECK(block[4096] == char(4096));
  }
  const ProcessMemory after = process_memory();
  CHECK(after.peak_rss_mb >= before.rss_mb + 240);  // the high-water mark keeps it
  CHECK(after.rss_mb < after.peak_rss_mb - 200);    // a block that large goes back to the system (mmap)
  CHECK(after.peak_rss_mb >= during.rss_mb);        // never below a figure read before
}
