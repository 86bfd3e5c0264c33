# Runs a libFuzzer executable for a bounded time: fresh seeds (every *.yaml under SEEDS), a
# corpus folder that keeps what it finds, crash artifacts in WORK/artifacts.
# cmake -DFUZZER=exe -DSEEDS=dir -DDICT=file -DWORK=dir -DSECONDS=n -P run_fuzzer.cmake
file(REMOVE_RECURSE ${WORK}/seeds)
file(MAKE_DIRECTORY ${WORK}/seeds ${WORK}/corpus ${WORK}/artifacts)
file(GLOB_RECURSE seeds ${SEEDS}/*.yaml)
list(LENGTH seeds count)
if(count EQUAL 0)
  message(FATAL_ERROR "no seed scenes under ${SEEDS}")
endif()
foreach(seed ${seeds})
  file(RELATIVE_PATH name ${SEEDS} ${seed})
  string(REPLACE "/" "_" name ${name})
  configure_file(${seed} ${WORK}/seeds/${name} COPYONLY)
endforeach()
message(STATUS "fuzzing ${FUZZER} for ${SECONDS} s from ${count} seeds")
execute_process(
  COMMAND ${FUZZER} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
          -dict=${DICT} -print_final_stats=1 -artifact_prefix=${WORK}/artifacts/
          ${WORK}/corpus ${WORK}/seeds
  WORKING_DIRECTORY ${WORK}
  RESULT_VARIABLE status
  OUTPUT_VARIABLE log
  ERROR_VARIABLE log)
file(WRITE ${WORK}/fuzz.log "${log}")
if(NOT status EQUAL 0)
  message("${log}")
  message(FATAL_ERROR "the fuzzer reported a finding (exit ${status}); reproduce with "
                      "${FUZZER} ${WORK}/artifacts/<file> (log: ${WORK}/fuzz.log)")
endif()
string(REGEX MATCHALL "stat::[a-z_]+: *[0-9]+" stats "${log}")
foreach(line ${stats})
  message(STATUS "${line}")
endforeach()
