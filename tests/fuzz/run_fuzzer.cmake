# Runs a libFuzzer executable for a bounded time: fresh seeds (every file matching PATTERN,
# default *.yaml, under SEEDS), a corpus folder that keeps what it finds, crash artifacts in
# WORK/artifacts. DICT (a libFuzzer dictionary) and MAX_LEN (the longest input, default
# libFuzzer's) are optional.
# cmake -DFUZZER=exe -DSEEDS=dir [-DPATTERN=glob] [-DDICT=file] -DWORK=dir -DSECONDS=n
#       -P run_fuzzer.cmake
if(NOT PATTERN)
  set(PATTERN "*.yaml")
endif()
file(REMOVE_RECURSE ${WORK}/seeds)
file(MAKE_DIRECTORY ${WORK}/seeds ${WORK}/corpus ${WORK}/artifacts)
file(GLOB_RECURSE seeds ${SEEDS}/${PATTERN})
list(LENGTH seeds count)
if(count EQUAL 0)
  message(FATAL_ERROR "no seeds matching ${PATTERN} under ${SEEDS}")
endif()
set(dict_option "")
if(DICT)
  set(dict_option "-dict=${DICT}")
endif()
set(max_len_option "")
if(MAX_LEN)
  set(max_len_option "-max_len=${MAX_LEN}")
endif()
foreach(seed ${seeds})
  file(RELATIVE_PATH name ${SEEDS} ${seed})
  string(REPLACE "/" "_" name ${name})
  configure_file(${seed} ${WORK}/seeds/${name} COPYONLY)
endforeach()
message(STATUS "fuzzing ${FUZZER} for ${SECONDS} s from ${count} seeds")
execute_process(
  COMMAND ${FUZZER} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
          ${dict_option} ${max_len_option} -print_final_stats=1 -artifact_prefix=${WORK}/artifacts/
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
