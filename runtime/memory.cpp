#include "runtime/memory.h"

#include <cstdio>
#include <cstring>

namespace polyhex {

ProcessMemory process_memory() noexcept {
  ProcessMemory m;
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return m;
  char line[256];
  while (std::fgets(line, sizeof line, f)) {
    long kib = 0;
    if (std::sscanf(line, "VmRSS: %ld kB", &kib) == 1) m.rss_mb = double(kib) / 1024.0;
    if (std::sscanf(line, "VmHWM: %ld kB", &kib) == 1) m.peak_rss_mb = double(kib) / 1024.0;
  }
  std::fclose(f);
  return m;
}

}  // namespace polyhex
