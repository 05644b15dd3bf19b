#include "runtime/cancel.h"

#include "runtime/errors.h"

#include <sys/syscall.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <dirent.h>
#include <mutex>
#include <pthread.h>
#include <signal.h>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace polyhex {

namespace {

std::atomic<int> g_signal{0};

// Why a watcher thread and not a plain handler: METIS (under CHOLMOD's ordering) replaces the SIGTERM
// handler while it runs (GKlib's gk_sigtrap: SIGERR = SIGTERM) with one that longjmps to a buffer of
// the thread running METIS. A SIGTERM in that window crashed polyhex (SIGSEGV in ____longjmp_chk
// when another thread took it) or was swallowed (the run went on and exited 0). So SIGINT and SIGTERM
// are blocked in every thread and taken by sigwait() in one watcher thread: no handler ever runs,
// whatever a library installs. The handler below stays installed for a thread that has not blocked
// them yet.

void record(int sig) {
  // Async-signal-safe only (also used by the handler): an atomic exchange, write(2), _exit(2).
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

extern "C" void on_signal(int sig) { record(sig); }

sigset_t interrupt_set() {
  sigset_t s;
  sigemptyset(&s);
  sigaddset(&s, SIGINT);
  sigaddset(&s, SIGTERM);
  return s;
}

// Threads started before main() (OpenBLAS's server, log4cplus's pool under OpenVDB) do not inherit
// the mask set in main(). Each is sent a real-time signal whose handler adds SIGINT and SIGTERM to the
// mask the thread returns to (uc_sigmask, restored by sigreturn).
extern "C" void on_block_request(int, siginfo_t*, void* context) {
  auto* uc = static_cast<ucontext_t*>(context);
  sigaddset(&uc->uc_sigmask, SIGINT);
  sigaddset(&uc->uc_sigmask, SIGTERM);
}

/// The blocked-signal mask of thread `tid` (SigBlk in /proc/self/task/TID/status); false if the
/// thread is gone.
bool blocked_mask(long tid, unsigned long long& mask) {
  const std::string path = "/proc/self/task/" + std::to_string(tid) + "/status";
  bool found = false;
  if (FILE* f = std::fopen(path.c_str(), "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, f))
      if (std::strncmp(line, "SigBlk:", 7) == 0) {
        mask = std::strtoull(line + 7, nullptr, 16);
        found = true;
      }
    std::fclose(f);
  }
  return found;
}

void block_in_other_threads() {
  const int request = SIGRTMIN + 3;
  struct sigaction sa {
  }, old{};
  sa.sa_sigaction = on_block_request;
  sa.sa_flags = SA_SIGINFO | SA_RESTART;
  // SIGINT and SIGTERM blocked while the handler runs too, so the thread's mask shows them from the
  // moment the handler starts until sigreturn installs uc_sigmask.
  sa.sa_mask = interrupt_set();
  if (sigaction(request, &sa, &old) != 0) return;
  const pid_t pid = ::getpid();
  const pid_t self = static_cast<pid_t>(::syscall(SYS_gettid));
  const auto bit = [](int sig) { return 1ULL << (sig - 1); };
  // Kernel signal 32 (glibc's SIGCANCEL) can only be blocked by glibc itself: pthread_create blocks
  // every signal around clone() and the new thread sets its real mask a moment later. A library that
  // starts threads in a constructor does not wait for that, so a thread seen in that state is polled
  // again rather than taken as "blocks everything" (it then unblocked SIGTERM and took the signal).
  const unsigned long long starting = bit(32);
  std::vector<long> asked;
  bool settled = false;
  const auto t0 = std::chrono::steady_clock::now();
  while (!settled && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(1)) {
    settled = true;
    DIR* d = ::opendir("/proc/self/task");
    if (!d) break;
    while (dirent* e = ::readdir(d)) {
      const long tid = std::strtol(e->d_name, nullptr, 10);
      unsigned long long mask = 0;
      if (tid <= 0 || tid == self || !blocked_mask(tid, mask)) continue;
      if (mask & starting) {
        settled = false;
        continue;
      }
      // Threads that block SIGINT and SIGTERM (log4cplus blocks every signal in its threads, and an
      // asked thread once its handler starts) need nothing; one that blocks the request cannot be asked.
      if ((mask & bit(SIGINT)) && (mask & bit(SIGTERM))) continue;
      if (mask & bit(request)) continue;
      settled = false;
      if (std::find(asked.begin(), asked.end(), tid) != asked.end()) continue;
      if (::syscall(SYS_tgkill, pid, static_cast<pid_t>(tid), request) == 0) asked.push_back(tid);
    }
    ::closedir(d);
    if (!settled) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // A thread that never ran the handler keeps the plain handler, as before; its request is then
  // ignored rather than left to the default action (which would end the process).
  if (settled) {
    sigaction(request, &old, nullptr);
  } else {
    struct sigaction ignore {};
    ignore.sa_handler = SIG_IGN;
    sigemptyset(&ignore.sa_mask);
    sigaction(request, &ignore, nullptr);
  }
}

void watch() {
  const sigset_t set = interrupt_set();
  for (;;) {
    int sig = 0;
    if (sigwait(&set, &sig) == 0) record(sig);
  }
}

}  // namespace

void install_interrupt_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    // Block in this thread (threads it starts later inherit the mask) and in the threads that exist.
    const sigset_t set = interrupt_set();
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    block_in_other_threads();
    std::thread(watch).detach();
  });
}

bool interrupted() { return g_signal.load(std::memory_order_relaxed) != 0; }
void request_interrupt() { g_signal.store(SIGINT); }
void clear_interrupt() { g_signal.store(0); }

void throw_if_interrupted() {
  int sig = g_signal.load(std::memory_order_relaxed);
  if (sig != 0) throw Interrupted(std::string("interrupted by ") + (sig == SIGTERM ? "SIGTERM" : "SIGINT"));
}

}  // namespace polyhex
