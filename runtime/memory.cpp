#include "runtime/memory.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>

namespace polyhex {
namespace {

/// The largest figure any call has read, KiB. Linux caches its resident counters per thread and syncs them
/// lazily, so a VmRSS read earlier can exceed a VmHWM read later by a fraction of a MiB (CI saw a node's
/// 76.82 MiB above the bench's peak of 76.63): the peak reported is at least every figure read before.
std::atomic<long> largest_kib{0};

long raise_largest(long kib) noexcept {
  long seen = largest_kib.load(std::memory_order_relaxed);
  while (seen < kib && !largest_kib.compare_exchange_weak(seen, kib, std::memory_order_relaxed)) {
  }
  return std::max(seen, kib);
}

}  // namespace

ProcessMemory process_memory() noexcept {
  ProcessMemory m;
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return m;
  char line[256];
  long rss = 0, hwm = 0;
  while (std::fgets(line, sizeof line, f)) {
    long kib = 0;
    if (std::sscanf(line, "VmRSS: %ld kB", &kib) == 1) rss = kib;
    if (std::sscanf(line, "VmHWM: %ld kB", &kib) == 1) hwm = kib;
  }
  std::fclose(f);
  m.rss_mb = double(rss) / 1024.0;
  m.peak_rss_mb = double(raise_largest(std::max(rss, hwm))) / 1024.0;
  return m;
}

}  // namespace polyhex
