# Generates the example sector matrices with the project's script, then runs the shipped
# fe_sector scene on them (from a copy in the build tree, so the source tree stays clean).
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
file(COPY ${SOURCE}/configs/fe_sector_example.yaml DESTINATION ${WORK})
foreach(step
    "python3;${SOURCE}/configs/models/make_example_sector.py;${WORK}/models/generated"
    "${FRICHB};--log-level;warn;run;${WORK}/fe_sector_example.yaml;-o;${WORK}/out")
  execute_process(COMMAND ${step} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "step failed (${rc}): ${step}\n${out}\n${err}")
  endif()
endforeach()
if(NOT EXISTS ${WORK}/out/response.csv)
  message(FATAL_ERROR "no response.csv written")
endif()
file(READ ${WORK}/out/summary.json summary)
if(NOT summary MATCHES "\"reached_end\": true")
  message(FATAL_ERROR "the response curve did not reach the end of the sweep")
endif()
