/// @file cancel.h
/// @brief Cooperative interruption. SIGINT/SIGTERM set a flag; long computations call
/// throw_if_interrupted() at safe points (NodeContext::progress does), the graph cancels, temporary
/// files are removed by their writers, and the CLI exits with 130. A second signal ends the process
/// at once.
#pragma once

namespace polyhex {

/// Installs the SIGINT and SIGTERM handling (idempotent). Call once from main(), early. Both signals
/// are blocked in every thread (the caller, threads it starts later, and the threads that already
/// exist) and taken by a watcher thread with sigwait(): libraries that install their own handlers
/// for a while (METIS traps SIGTERM during an ordering) can then neither crash nor swallow them.
/// Processes started afterwards inherit the blocked mask: give them an empty one
/// (posix_spawnattr_setsigmask) when they should see these signals.
void install_interrupt_handlers();
/// True after SIGINT/SIGTERM (or request_interrupt()).
bool interrupted();
/// Sets the flag as a signal would (tests, embedding applications).
void request_interrupt();
/// Clears the flag (tests).
void clear_interrupt();
/// \throw Interrupted when interrupted() is true
void throw_if_interrupted();

}  // namespace polyhex
