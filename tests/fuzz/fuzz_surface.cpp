// libFuzzer target: read_surface on OBJ / OFF / STL / PLY (byte 0 % 4 picks the extension).
#include "runtime/errors.h"
#include "tests/fuzz/fuzz_common.h"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    polyhex::SurfaceReadReport report;
    polyhex::SurfaceMesh m = polyhex_fuzz::read_surface_input(data, size, &report);
    // An accepted surface satisfies the reader's postconditions.
    polyhex_fuzz::require_indices_in_range(m.F, m.V.rows());
    if (!m.V.allFinite() || report.faces != m.F.rows() || report.vertices != m.V.rows()) __builtin_trap();
  } catch (const polyhex::Error&) {
  }
  return 0;
}
