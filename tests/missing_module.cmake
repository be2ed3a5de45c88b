# A clogging run whose CHOLMOD module cannot be found must stop on both ranks with an error that
# names the module, the folder it looked in and how to point at another, and say so in the run's
# summary.json; never hang the other rank.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/no-module)
execute_process(COMMAND ${CMAKE_COMMAND} -E env CASSINI_MODULE_DIR=${WORK}/no-module
                        ${MPIEXEC} -n 2 ${MPI_FLAGS} ${EXE} ${CASE} --out ${WORK}/run
                        --set flow.cache=${WORK}/cache --set time.end=1e-6
                TIMEOUT 300 RESULT_VARIABLE r OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(r EQUAL 0 OR r MATCHES "timeout")
  message(FATAL_ERROR "a run without its module did not stop with an error: ${r}\n${err}")
endif()
foreach(expected "libcassini_cholmod.so" "CASSINI_MODULE_DIR" "${WORK}/no-module")
  string(FIND "${out}${err}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "the error does not name '${expected}':\n${out}${err}")
  endif()
endforeach()
file(READ ${WORK}/run/summary.json summary)
if(NOT summary MATCHES "\"status\": \"error\"" OR NOT summary MATCHES "libcassini_cholmod.so")
  message(FATAL_ERROR "summary.json does not record the error:\n${summary}")
endif()
