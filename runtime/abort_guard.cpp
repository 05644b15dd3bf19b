// SIGABRT caught around one call. See abort_guard.h.
#include "runtime/abort_guard.h"

#include <csetjmp>
#include <csignal>
#include <mutex>

namespace polyhex {
namespace {

/// The way out of the guarded call running in this thread, or null (a static TLS slot of the executable:
/// reading it in the handler takes no lock).
thread_local sigjmp_buf* t_escape = nullptr;

extern "C" void on_abort(int) {
  if (t_escape) siglongjmp(*t_escape, 1);
  // another thread's abort(): returning lets abort() go on and end the process
}

/// The handler is installed while at least one guard runs, and the one before it put back after the last.
std::mutex g_mutex;
int g_active = 0;
struct sigaction g_previous;

void enter() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_active++ > 0) return;
  struct sigaction act {};
  act.sa_handler = on_abort;
  sigemptyset(&act.sa_mask);
  act.sa_flags = 0;
  sigaction(SIGABRT, &act, &g_previous);
}

void leave() {
  t_escape = nullptr;
  std::lock_guard<std::mutex> lock(g_mutex);
  if (--g_active == 0) sigaction(SIGABRT, &g_previous, nullptr);
}

}  // namespace

bool returns_without_abort(const std::function<void()>& f) {
  enter();
  sigjmp_buf env;
  if (sigsetjmp(env, 1) != 0) {  // back from abort() (the signal mask restored by siglongjmp)
    leave();
    return false;
  }
  t_escape = &env;
  try {
    f();
  } catch (...) {
    leave();
    throw;
  }
  leave();
  return true;
}

}  // namespace polyhex
