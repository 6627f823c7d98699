# Installs the project into a scratch prefix, then configures, builds and runs a GIS-client
# example (examples/<EXAMPLE>) against the installed StencilGis package, as a client would.
# Arguments: -DBUILD_DIR=<project build> -DSOURCE_DIR=<project source> -DWORK_DIR=<scratch>
# -DEXAMPLE=<client_overlay|client_scene> [-DEXAMPLE_ARGS=<arguments of the program>].
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "failed (${result}): ${ARGV}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/${EXAMPLE} -B ${WORK_DIR}/build -G Ninja
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
execute_process(COMMAND ${WORK_DIR}/build/${EXAMPLE} ${EXAMPLE_ARGS} WORKING_DIRECTORY ${WORK_DIR}
                RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "${out}${err}")
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${EXAMPLE} failed (${result})")
endif()
