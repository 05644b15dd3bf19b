# Find TetGen 1.5 as a library (Debian libtet1.5-dev). Defines TetGen::TetGen.
# tetgen.h must be compiled with TETLIBRARY defined; the target carries that definition.
find_path(TETGEN_INCLUDE_DIR tetgen.h)
find_library(TETGEN_LIBRARY tet)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(TetGen DEFAULT_MSG TETGEN_LIBRARY TETGEN_INCLUDE_DIR)
if(TetGen_FOUND AND NOT TARGET TetGen::TetGen)
  add_library(TetGen::TetGen INTERFACE IMPORTED)
  set_target_properties(TetGen::TetGen PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${TETGEN_INCLUDE_DIR}"
    INTERFACE_COMPILE_DEFINITIONS "TETLIBRARY"
    INTERFACE_LINK_LIBRARIES "${TETGEN_LIBRARY}")
endif()
