#include "runtime/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <system_error>

#include "runtime/errors.h"

namespace polyhex {

void write_file_atomic(const std::filesystem::path& path, const std::function<void(std::ostream&)>& fill,
                       bool binary) {
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  auto cleanup = [&] {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
  };
  {
    std::ofstream out(tmp, binary ? std::ios::binary | std::ios::out : std::ios::out);
    if (!out) throw IOError(path.string() + ": cannot open for writing");
    try {
      fill(out);
    } catch (...) {
      out.close();
      cleanup();
      throw;
    }
    out.flush();
    if (!out) {
      out.close();
      cleanup();
      throw IOError(path.string() + ": write failed (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    cleanup();
    throw IOError(path.string() + ": cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace polyhex
