/// @file stopwatch.h
/// @brief Wall time in seconds on the steady clock: the one helper behind every `seconds` figure and time budget.
#pragma once

#include <chrono>

namespace polyhex {

/// Seconds elapsed since t0 (steady clock).
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace polyhex
