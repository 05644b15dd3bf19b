# Find the Exodus II C library (Debian libexodusii-dev: exodusII.h, libexoIIv2c, on netCDF). Defines
# ExodusII::ExodusII. exodusII.h includes netcdf.h and netcdf_par.h (Debian's netCDF with MPI), so the
# target carries their folders and links netCDF too.
find_path(EXODUSII_INCLUDE_DIR exodusII.h)
find_library(EXODUSII_LIBRARY exoIIv2c)
find_path(NETCDF_INCLUDE_DIR netcdf.h)
find_library(NETCDF_LIBRARY netcdf)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(ExodusII DEFAULT_MSG EXODUSII_LIBRARY EXODUSII_INCLUDE_DIR NETCDF_LIBRARY
                                  NETCDF_INCLUDE_DIR)
if(ExodusII_FOUND AND NOT TARGET ExodusII::ExodusII)
  add_library(ExodusII::ExodusII INTERFACE IMPORTED)
  set_target_properties(ExodusII::ExodusII PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${EXODUSII_INCLUDE_DIR};${NETCDF_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${EXODUSII_LIBRARY};${NETCDF_LIBRARY}")
endif()
