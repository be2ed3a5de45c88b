# cassini maps only what every run needs: CHOLMOD with its BLAS/LAPACK/Fortran runtime is a
# module loaded by the Stokes solve (libcassini_cholmod.so), and HDF5 is linked from its static
# archive, so Debian's libcurl with its TLS and Kerberos stack (HDF5's S3 driver) is not loaded.
# MPI's deprecated C++ bindings (libmpi_cxx) are left out too (cassini calls the C interface).
# Each of those costs every rank resident memory (~10 MB per rank together; docs/benchmarks.md).
# Fails when the executable EXE names one of them as a needed library.
execute_process(COMMAND readelf -d ${EXE} OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "readelf -d ${EXE} failed (${rc})")
endif()
string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" needed "${dynamic}")
if(NOT needed)
  message(FATAL_ERROR "readelf -d ${EXE} lists no needed libraries: not a dynamic executable?")
endif()
foreach(lib ${needed})
  if(lib MATCHES "cholmod|blas|lapack|gfortran|curl|crypto|ssl|gnutls|hdf5|mpi_cxx")
    message(FATAL_ERROR "${EXE} loads ${lib} at start; it should not (see tests/lean_binary.cmake)")
  endif()
endforeach()
message(STATUS "${EXE} needs: ${needed}")
