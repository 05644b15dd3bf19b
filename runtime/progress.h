/// @file progress.h
/// @brief Progress: the callback a long stage reports through (ProgressFn), and what `polyhex run` shows
/// on stderr while a pipeline runs (RunOptions::on_event).
///
/// - On a terminal (stderr is a tty, no -v): one line that updates in place (`\r`, erase to the end)
///   with the node that reported last, `[polycube] ########------------  42% untangle`, and a
///   permanent line when a node ends (`done in`, `loaded from cache in`).
/// - With -v (terminal or not): one line per event, as before: started, progress, done, cached.
/// - Otherwise (logs, CI): nothing.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

namespace polyhex {

/// How a long compute function reports how far it is: `fraction` in [0, 1] of its work, `what` the phase.
/// An empty function is allowed (nothing reported). A node binding passes NodeContext::progress_fn(), which
/// is also a cancellation point (\throw Interrupted after SIGINT/SIGTERM).
using ProgressFn = std::function<void(double fraction, const std::string& what)>;

enum class ProgressMode { quiet, bar, lines };

/// The mode for a verbosity (-v count) and whether stderr is a terminal.
ProgressMode progress_mode(int verbosity, bool stderr_is_terminal);

/// The bar's line: `[id] ` then `bar` cells, `#` for the done share (rounded down) and `-` for the rest,
/// the percentage (rounded down, 3 wide) and `what`, cut to `width` characters (no line break).
/// A fraction outside [0, 1] (or NaN) is shown as the nearest end (NaN as 0).
/// \pre bar >= 1
std::string progress_bar_line(const std::string& id, double fraction, const std::string& what, int width, int bar = 20);

/// Columns of the terminal on `fd` (80 when it is not a terminal or does not say).
int terminal_columns(int fd);

/// Prints the events of one run to `out` in a mode. Not thread-safe: the pipeline serializes its events.
class ProgressPrinter {
 public:
  /// \param width  columns of the bar's line (terminal_columns)
  ProgressPrinter(std::FILE* out, ProgressMode mode, int width = 80);
  /// Erases the bar's line when one is shown.
  ~ProgressPrinter();
  ProgressPrinter(const ProgressPrinter&) = delete;
  ProgressPrinter& operator=(const ProgressPrinter&) = delete;

  /// One event of RunOptions::on_event: "start", "progress" (value = fraction), "done" and "cached"
  /// (value = seconds). In bar mode a progress event redraws the line only when its text changes and at
  /// most every 50 ms, unless it reaches 100 %.
  void event(const std::string& e, const std::string& id, const std::string& type, double value,
             const std::string& what);
  /// Erases the bar's line (before other output), if one is shown.
  void clear();

 private:
  void draw(const std::string& line, bool force);
  std::FILE* out_;
  ProgressMode mode_;
  int width_;
  std::string shown_;  ///< the bar's line on screen, "" when none
  std::chrono::steady_clock::time_point drawn_at_{};
};

}  // namespace polyhex
