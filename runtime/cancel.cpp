#include "runtime/cancel.h"

#include <csignal>
#include <unistd.h>

#include <atomic>

#include "runtime/errors.h"

namespace polyhex {

namespace {

std::atomic<int> g_signal{0};

extern "C" void on_signal(int sig) {
  // Async-signal-safe only: an atomic store, write(2), _exit(2).
  if (g_signal.exchange(sig) != 0) {
    static const char msg[] = "\npolyhex: interrupted again, exiting now\n";
    ssize_t ignored = ::write(STDERR_FILENO, msg, sizeof(msg) - 1);
    (void)ignored;
    ::_exit(128 + sig);
  }
  static const char msg[] = "\npolyhex: interrupt received, stopping at the next safe point (again to quit now)\n";
  ssize_t ignored = ::write(STDERR_FILENO, msg, sizeof(msg) - 1);
  (void)ignored;
}

}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool interrupted() { return g_signal.load(std::memory_order_relaxed) != 0; }
void request_interrupt() { g_signal.store(SIGINT); }
void clear_interrupt() { g_signal.store(0); }

void throw_if_interrupted() {
  int sig = g_signal.load(std::memory_order_relaxed);
  if (sig != 0) throw Interrupted(std::string("interrupted by ") + (sig == SIGTERM ? "SIGTERM" : "SIGINT"));
}

}  // namespace polyhex
