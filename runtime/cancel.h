/// @file cancel.h
/// @brief Cooperative interruption. SIGINT/SIGTERM set a flag; long computations call
/// throw_if_interrupted() at safe points (NodeContext::progress does), the graph cancels, temporary
/// files are removed by their writers, and the CLI exits with 130. A second signal ends the process
/// at once.
#pragma once

namespace polyhex {

/// Installs the SIGINT and SIGTERM handlers (idempotent). Call once from main().
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
