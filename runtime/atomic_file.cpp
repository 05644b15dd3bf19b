#include "runtime/atomic_file.h"

#include "runtime/errors.h"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>
#include <unistd.h>

namespace polyhex {

namespace {

/// The reason of the last failed system call, e.g. "No space left on device"; "" when errno is 0.
std::string reason(int err) { return err != 0 ? std::string(": ") + std::strerror(err) : std::string(); }

/// Checks that `path` can be a file and returns a fresh temporary name beside it.
std::filesystem::path temporary_name(const std::filesystem::path& path) {
  static std::atomic<unsigned> counter{0};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw IOError(path.string() + ": cannot write the file: a folder of that name exists");
  const std::filesystem::path parent = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  if (std::filesystem::exists(parent, ec) && !std::filesystem::is_directory(parent, ec))
    throw IOError(path.string() + ": cannot write the file: " + parent.string() + " is a file, not a folder");
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  return tmp;
}

/// Renames tmp to path; on failure removes tmp. \throw IOError
void rename_into_place(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code e;
    std::filesystem::remove(tmp, e);
    throw IOError(path.string() + ": cannot rename the temporary file into place: " + ec.message());
  }
}

}  // namespace

void write_file_atomic_by_name(const std::filesystem::path& path,
                               const std::function<void(const std::filesystem::path& tmp)>& write) {
  const std::filesystem::path tmp = temporary_name(path);
  std::error_code ec;
  try {
    write(tmp);
  } catch (...) {
    std::filesystem::remove(tmp, ec);
    throw;
  }
  if (!std::filesystem::is_regular_file(tmp, ec)) {
    std::filesystem::remove(tmp, ec);
    throw IOError(path.string() + ": the writer left no file; no file written");
  }
  rename_into_place(tmp, path);
}

void write_file_atomic(const std::filesystem::path& path, const std::function<void(std::ostream&)>& fill, bool binary) {
  const std::filesystem::path tmp = temporary_name(path);
  auto cleanup = [&] {
    std::error_code e;
    std::filesystem::remove(tmp, e);
  };
  {
    errno = 0;
    std::ofstream out(tmp, binary ? std::ios::binary | std::ios::out : std::ios::out);
    if (!out) {
      const int err = errno;
      cleanup();
      throw IOError(path.string() + ": cannot open for writing" + reason(err));
    }
    errno = 0;
    try {
      fill(out);
    } catch (...) {
      out.close();
      cleanup();
      throw;
    }
    // A full disk or a file size limit shows while filling, when the buffer is flushed or when the
    // file is closed.
    int err = out ? 0 : errno;
    if (out) {
      errno = 0;
      out.flush();
      if (!out) err = errno;
    }
    if (out) {
      errno = 0;
      out.close();
      if (out.fail()) err = errno;
    }
    if (out.fail()) {
      out.close();
      cleanup();
      throw IOError(path.string() + ": write failed" + (err ? reason(err) : std::string(" (disk full?)")) +
                    "; no file written");
    }
  }
  rename_into_place(tmp, path);
}

}  // namespace polyhex
