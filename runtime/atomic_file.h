/// @file atomic_file.h
/// @brief Write a file under a temporary name in the same folder, then rename it into place, so a
/// reader never sees a half-written output, even when the writer fails or the process dies.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>

namespace polyhex {

/// Calls `fill` with a stream on `path.tmp.<pid>.<n>`, flushes, closes, checks the stream and renames.
/// Whatever fails (a full disk, a file size limit, an unwritable or missing folder, `fill` throwing),
/// no file is left under `path` (an existing file there is kept unchanged) and the temporary file is
/// removed.
/// \param binary open the stream in binary mode
/// \throw IOError naming `path` and the system's reason ("No space left on device", "File too
///        large", "Permission denied") when the file cannot be opened, written, closed or renamed,
///        when `path` is an existing folder or its parent is a file. Exceptions thrown by `fill` are
///        rethrown after the clean-up.
void write_file_atomic(const std::filesystem::path& path, const std::function<void(std::ostream&)>& fill,
                       bool binary = false);

/// The same for a library that writes a file by name (the Exodus II library): calls `write` with the
/// temporary name `path.tmp.<pid>.<n>` in the same folder, then renames that file into place. When `write`
/// throws or leaves no file, no file is left under `path` (an existing one is kept) nor under the
/// temporary name.
/// \throw IOError naming `path` as write_file_atomic; exceptions thrown by `write` are rethrown after the clean-up
void write_file_atomic_by_name(const std::filesystem::path& path,
                               const std::function<void(const std::filesystem::path& tmp)>& write);

}  // namespace polyhex
