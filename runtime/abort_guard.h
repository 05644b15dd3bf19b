/// @file abort_guard.h
/// @brief Survives a library's failed assert(). TetGen 1.5.0, as Debian builds it, checks itself with
/// assert(): on some surfaces, in some frames, a check fails and abort() would end the process (TetGen
/// 1.5.0 on in-volume_twist in its canonical placement, nodes/orient/placement.h). While a guard runs, a
/// SIGABRT handler is installed (the one before it is put back after the last guard): SIGABRT raised in a
/// guarded call's own thread jumps back out of the call; in any other thread abort() ends the process as
/// always.
#pragma once

#include <functional>

namespace polyhex {

/// Runs f(): true if it returned, false if it called abort() (the process goes on; what f had allocated
/// is lost, and objects whose lifetime began inside f are not destroyed, so f should own nothing that
/// outlives it). Exceptions f throws pass through. One guard at a time per thread; guards in other
/// threads may run at the same time.
bool returns_without_abort(const std::function<void()>& f);

}  // namespace polyhex
