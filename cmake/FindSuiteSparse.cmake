# Debian's SuiteSparse 5.12 ships no CMake config and no pkg-config file
# (DEPENDENCIES.md). This module finds the headers and the libraries peristat uses and
# makes one imported target, SuiteSparse::SuiteSparse.
find_path(SuiteSparse_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
set(_ss_libs cholmod umfpack klu amd colamd camd ccolamd btf suitesparseconfig)
set(_ss_found_libs)
foreach(lib IN LISTS _ss_libs)
  find_library(SuiteSparse_${lib}_LIBRARY ${lib})
  if(SuiteSparse_${lib}_LIBRARY)
    list(APPEND _ss_found_libs ${SuiteSparse_${lib}_LIBRARY})
  endif()
endforeach()
find_package(BLAS)
find_package(LAPACK)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SuiteSparse
  REQUIRED_VARS SuiteSparse_INCLUDE_DIR SuiteSparse_cholmod_LIBRARY SuiteSparse_umfpack_LIBRARY
                SuiteSparse_klu_LIBRARY SuiteSparse_amd_LIBRARY SuiteSparse_suitesparseconfig_LIBRARY)
if(SuiteSparse_FOUND AND NOT TARGET SuiteSparse::SuiteSparse)
  add_library(SuiteSparse::SuiteSparse INTERFACE IMPORTED)
  set_target_properties(SuiteSparse::SuiteSparse PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${SuiteSparse_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_ss_found_libs};${LAPACK_LIBRARIES};${BLAS_LIBRARIES}")
endif()
mark_as_advanced(SuiteSparse_INCLUDE_DIR)
