/// @file fuzz_common.h
/// @brief Shared helpers of the libFuzzer targets in tests/fuzz: the readers take paths, so a target
/// writes the fuzzer's bytes to a file in a per-process scratch folder (on /dev/shm when it exists)
/// and calls the reader on it. Expected failures are polyhex::Error; anything else escaping (another
/// exception type, a crash, a sanitizer report) is a finding.
///
/// Input layout of the reader targets: byte 0 selects the file extension (`byte % count`), the rest
/// is the file content. tools/fuzz.sh builds the seed corpus in this layout from tests/fixtures.
#pragma once

#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <unistd.h>
#include <utility>

namespace polyhex_fuzz {

/// Per-process scratch folder, created on first use, removed at exit.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path base = std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                                     : std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("polyhex_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  static const bool cleanup = [] {
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratch_dir(), ec);
    });
    return true;
  }();
  (void)cleanup;
  return dir;
}

/// Writes `bytes` to scratch_dir()/name and returns the path. Aborts when the write fails (that is
/// the harness failing, not the reader).
inline std::filesystem::path write_scratch(const std::string& name, std::string_view bytes) {
  std::filesystem::path p = scratch_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", p.c_str());
    std::abort();
  }
  return p;
}

/// Splits the fuzzer input into (selector, content). An empty input gives selector 0, no content.
inline std::pair<unsigned, std::string_view> split_selector(const uint8_t* data, size_t size) {
  if (size == 0) return {0u, {}};
  return {unsigned(data[0]), std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1)};
}

/// Postcondition of every reader: each cell index in [0, n). Traps (a finding) otherwise.
template <class Cells>
void require_indices_in_range(const Cells& cells, Eigen::Index n) {
  for (Eigen::Index i = 0; i < cells.size(); ++i)
    if (cells.data()[i] < 0 || cells.data()[i] >= n) __builtin_trap();
}

// The readers on a fuzzer input (layout above). Each throws what the reader throws.

/// read_surface: byte 0 % 4 picks .obj .off .stl .ply.
inline polyhex::SurfaceMesh read_surface_input(const uint8_t* data, size_t size, polyhex::SurfaceReadReport* report) {
  static const char* const kExt[] = {".obj", ".off", ".stl", ".ply"};
  auto [sel, content] = split_selector(data, size);
  return polyhex::read_surface(write_scratch(std::string("in") + kExt[sel % 4], content), report);
}

/// read_tetmesh: byte 0 % 4 picks .mesh .vtk .msh or TetGen; for TetGen the content is split at the
/// first NUL byte: .node before it, .ele after it.
inline polyhex::TetMesh read_tetmesh_input(const uint8_t* data, size_t size, polyhex::TetReadReport* report) {
  static const char* const kExt[] = {".mesh", ".vtk", ".msh", ".node"};
  auto [sel, content] = split_selector(data, size);
  if (sel % 4 == 3) {
    const size_t cut = content.find('\0');
    const std::string_view ele = cut == std::string_view::npos ? std::string_view() : content.substr(cut + 1);
    write_scratch("in.ele", ele);
    return polyhex::read_tetmesh(write_scratch("in.node", content.substr(0, cut)), report);
  }
  return polyhex::read_tetmesh(write_scratch(std::string("in") + kExt[sel % 4], content), report);
}

/// read_hexmesh: byte 0 % 3 picks .vtk .mesh .msh.
inline polyhex::HexMesh read_hexmesh_input(const uint8_t* data, size_t size, polyhex::HexReadReport* report) {
  static const char* const kExt[] = {".vtk", ".mesh", ".msh"};
  auto [sel, content] = split_selector(data, size);
  return polyhex::read_hexmesh(write_scratch(std::string("in") + kExt[sel % 3], content), report);
}

}  // namespace polyhex_fuzz
