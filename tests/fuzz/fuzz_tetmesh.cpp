// libFuzzer target: read_tetmesh on .mesh / .vtk / .msh / TetGen .node+.ele (byte 0 % 4 picks the
// format; for TetGen the content is split at the first NUL byte: .node before it, .ele after it).
#include "runtime/errors.h"
#include "tests/fuzz/fuzz_common.h"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    polyhex::TetReadReport report;
    polyhex::TetMesh m = polyhex_fuzz::read_tetmesh_input(data, size, &report);
    polyhex_fuzz::require_indices_in_range(m.T, m.V.rows());
    if (!m.V.allFinite() || m.T.rows() == 0) __builtin_trap();
  } catch (const polyhex::Error&) {
  }
  return 0;
}
