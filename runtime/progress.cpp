#include "runtime/progress.h"

#include <sys/ioctl.h>

#include <algorithm>
#include <cmath>
#include <unistd.h>

namespace polyhex {

ProgressMode progress_mode(int verbosity, bool stderr_is_terminal) {
  if (verbosity > 0) return ProgressMode::lines;
  return stderr_is_terminal ? ProgressMode::bar : ProgressMode::quiet;
}

std::string progress_bar_line(const std::string& id, double fraction, const std::string& what, int width, int bar) {
  const double f = std::isnan(fraction) ? 0.0 : std::clamp(fraction, 0.0, 1.0);
  const int filled = std::min(bar, int(std::floor(f * bar)));
  char pct[8];
  std::snprintf(pct, sizeof pct, "%3d%%", std::clamp(int(std::floor(f * 100)), 0, 100));
  std::string line =
      "[" + id + "] " + std::string(size_t(filled), '#') + std::string(size_t(bar - filled), '-') + " " + pct;
  if (!what.empty()) line += " " + what;
  if (width >= 0 && line.size() > size_t(width)) line.resize(size_t(width));
  return line;
}

int terminal_columns(int fd) {
  winsize w{};
  if (::isatty(fd) && ::ioctl(fd, TIOCGWINSZ, &w) == 0 && w.ws_col > 0) return int(w.ws_col);
  return 80;
}

ProgressPrinter::ProgressPrinter(std::FILE* out, ProgressMode mode, int width)
    : out_(out), mode_(mode), width_(width) {}

ProgressPrinter::~ProgressPrinter() { clear(); }

void ProgressPrinter::clear() {
  if (shown_.empty()) return;
  std::fputs("\r\033[K", out_);
  std::fflush(out_);
  shown_.clear();
}

void ProgressPrinter::draw(const std::string& line, bool force) {
  const auto now = std::chrono::steady_clock::now();
  if (line == shown_ || (!force && !shown_.empty() && now - drawn_at_ < std::chrono::milliseconds(50))) return;
  std::fprintf(out_, "\r\033[K%s", line.c_str());
  std::fflush(out_);
  shown_ = line;
  drawn_at_ = now;
}

void ProgressPrinter::event(const std::string& e, const std::string& id, const std::string& type, double value,
                            const std::string& what) {
  if (mode_ == ProgressMode::quiet) return;
  if (e == "done" || e == "cached") {  // a permanent line in both modes
    clear();
    std::fprintf(out_, "polyhex: %-16s %-34s %s %.2f s\n", id.c_str(), type.c_str(),
                 e == "done" ? "done in" : "loaded from cache in", value);
    std::fflush(out_);
  } else if (mode_ == ProgressMode::lines) {
    if (e == "start") std::fprintf(out_, "polyhex: %-16s %-34s started\n", id.c_str(), type.c_str());
    if (e == "skipped") std::fprintf(out_, "polyhex: %-16s %-34s skipped (no input)\n", id.c_str(), type.c_str());
    if (e == "progress") std::fprintf(out_, "polyhex: %-16s %3.0f%% %s\n", id.c_str(), 100 * value, what.c_str());
  } else {
    // One column short of the width: a line that fills the terminal wraps on some terminals.
    const int width = std::max(1, width_ - 1);
    if (e == "start") draw(progress_bar_line(id, 0, "started", width), true);
    if (e == "progress") draw(progress_bar_line(id, value, what, width), value >= 1);
  }
}

}  // namespace polyhex
