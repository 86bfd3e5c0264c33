# Installs this build into a temporary prefix, builds plugins/example against it with
# find_package(FricHB) as a third party would, and runs the example's own tests (the
# conformance kit on the plugin, and a scene that uses it).
set(prefix ${WORK}/prefix)
set(example_build ${WORK}/example-build)
file(REMOVE_RECURSE ${WORK})
foreach(step
    "${CMAKE_COMMAND};--install;${BUILD};--prefix;${prefix}"
    "${CMAKE_COMMAND};-S;${SOURCE}/plugins/example;-B;${example_build};-DCMAKE_PREFIX_PATH=${prefix};-DCMAKE_BUILD_TYPE=Release"
    "${CMAKE_COMMAND};--build;${example_build}"
    "${CMAKE_CTEST_COMMAND};--test-dir;${example_build};--output-on-failure")
  execute_process(COMMAND ${step} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "step failed (${rc}): ${step}\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${step}")
endforeach()
message(STATUS "${out}")
