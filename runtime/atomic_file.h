/// @file atomic_file.h
/// @brief Write a file under a temporary name in the same folder, then rename it into place, so a
/// reader never sees a half-written output, even when the writer fails or the process dies.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>

namespace polyhex {

/// Calls `fill` with a stream on `path.tmp.<pid>.<n>`, flushes, checks the stream and renames.
/// \param binary open the stream in binary mode
/// \throw IOError naming `path` when the file cannot be opened, written or renamed; the temporary
///        file is removed. Exceptions thrown by `fill` are rethrown after the clean-up.
void write_file_atomic(const std::filesystem::path& path, const std::function<void(std::ostream&)>& fill,
                       bool binary = false);

}  // namespace polyhex
