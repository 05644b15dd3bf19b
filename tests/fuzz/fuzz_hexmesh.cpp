// libFuzzer target: read_hexmesh on .vtk / .mesh / .msh (byte 0 % 3 picks the extension).
#include "runtime/errors.h"
#include "tests/fuzz/fuzz_common.h"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    polyhex::HexReadReport report;
    polyhex::HexMesh m = polyhex_fuzz::read_hexmesh_input(data, size, &report);
    polyhex_fuzz::require_indices_in_range(m.H, m.V.rows());
    if (m.H.rows() == 0) __builtin_trap();
  } catch (const polyhex::Error&) {
  }
  return 0;
}
