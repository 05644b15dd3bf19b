/// @file memory.h
/// @brief The process's resident memory, as Linux reports it (/proc/self/status): the figures each node
/// of a run records (graph/pipeline.h NodeRecord) and `polyhex bench` reports per node.
#pragma once

namespace polyhex {

struct ProcessMemory {
  double rss_mb = 0;       ///< resident set now (VmRSS), MiB
  double peak_rss_mb = 0;  ///< high-water mark of the resident set since the process started (VmHWM), MiB,
                           ///< and at least every figure an earlier call read (Linux updates VmHWM lazily)
};

/// The current figures; both 0 where /proc/self/status cannot be read (not Linux). Never throws.
ProcessMemory process_memory() noexcept;

}  // namespace polyhex
