# Installs this build into a temporary prefix and uses it as a third party would:
#  - builds plugins/example with find_package(FricHB) and runs the example's own tests (the
#    conformance kit on the plugin, and a scene that uses it);
#  - builds tests/core_consumer with find_package(FricHB COMPONENTS core conformance) and runs
#    its programs (a shipped scene loaded and prepared with the core API; the conformance kit
#    called from C++);
#  - checks that an unknown component fails find_package, naming it.
set(prefix ${WORK}/prefix)
set(example_build ${WORK}/example-build)
set(consumer_build ${WORK}/consumer-build)
set(unknown_source ${WORK}/unknown-component)
file(REMOVE_RECURSE ${WORK})
file(WRITE ${unknown_source}/CMakeLists.txt
     "cmake_minimum_required(VERSION 3.22)\n"
     "project(frichb_unknown_component LANGUAGES NONE)\n"
     "find_package(FricHB REQUIRED COMPONENTS no_such_component)\n")
foreach(step
    "${CMAKE_COMMAND};--install;${BUILD};--prefix;${prefix}"
    "${CMAKE_COMMAND};-S;${SOURCE}/plugins/example;-B;${example_build};-DCMAKE_PREFIX_PATH=${prefix};-DCMAKE_BUILD_TYPE=Release"
    "${CMAKE_COMMAND};--build;${example_build}"
    "${CMAKE_CTEST_COMMAND};--test-dir;${example_build};--output-on-failure"
    "${CMAKE_COMMAND};-S;${SOURCE}/tests/core_consumer;-B;${consumer_build};-DCMAKE_PREFIX_PATH=${prefix};-DCMAKE_BUILD_TYPE=Release"
    "${CMAKE_COMMAND};--build;${consumer_build}"
    "${CMAKE_CTEST_COMMAND};--test-dir;${consumer_build};--output-on-failure;-V")
  execute_process(COMMAND ${step} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "step failed (${rc}): ${step}\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${step}")
endforeach()
message(STATUS "${out}")

execute_process(
  COMMAND ${CMAKE_COMMAND} -S ${unknown_source} -B ${WORK}/unknown-component-build
          -DCMAKE_PREFIX_PATH=${prefix}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT "${out}${err}" MATCHES "no_such_component")
  message(FATAL_ERROR "find_package(FricHB COMPONENTS no_such_component) did not fail naming "
                      "the component (${rc}):\n${out}\n${err}")
endif()
message(STATUS "ok: an unknown component fails find_package")
