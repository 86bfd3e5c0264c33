# A study run by `mpirun -n 2 frichb study` equals the same study run by one process:
# the same index (every column but the wall time) and byte-identical response curves.
# Inputs: -DFRICHB=<frichb> -DMPIEXEC=<mpiexec> -DSOURCE=<source dir> -DWORK=<scratch dir>
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
file(READ ${SOURCE}/configs/quickstart_friction_oscillator.yaml scene)
string(REPLACE "plots: true" "plots: false" scene "${scene}")
string(APPEND scene "
study:
  sweep:
    - {path: contacts.root_friction.params.normal_load, values: [1.0, 2.5, 5.0, 10.0, 40.0]}
  parallel: 1
")
file(WRITE ${WORK}/scene.yaml "${scene}")

execute_process(COMMAND ${FRICHB} study ${WORK}/scene.yaml -o ${WORK}/serial
                RESULT_VARIABLE serial_code OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT serial_code EQUAL 0)
  message(FATAL_ERROR "serial study failed (${serial_code}):\n${out}")
endif()
# OpenMPI refuses root without these; in containers, shared-memory single copy may fail.
set(ENV{OMPI_ALLOW_RUN_AS_ROOT} 1)
set(ENV{OMPI_ALLOW_RUN_AS_ROOT_CONFIRM} 1)
set(ENV{OMPI_MCA_btl_vader_single_copy_mechanism} none)
set(ENV{OMPI_MCA_rmaps_base_oversubscribe} 1)
execute_process(COMMAND ${MPIEXEC} -n 2 ${FRICHB} study ${WORK}/scene.yaml -o ${WORK}/mpi
                RESULT_VARIABLE mpi_code OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT mpi_code EQUAL 0)
  message(FATAL_ERROR "2-rank study failed (${mpi_code}):\n${out}")
endif()

function(index_without_wall_time file result)
  file(STRINGS ${file} lines)
  set(kept "")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE ",[^,]*$" "" line "${line}")
    string(APPEND kept "${line}\n")
  endforeach()
  set(${result} "${kept}" PARENT_SCOPE)
endfunction()
index_without_wall_time(${WORK}/serial/study.csv serial_index)
index_without_wall_time(${WORK}/mpi/study.csv mpi_index)
if(NOT serial_index STREQUAL mpi_index)
  message(FATAL_ERROR "study.csv differs:\nserial:\n${serial_index}\n2 ranks:\n${mpi_index}")
endif()
string(REGEX MATCHALL "\n[0-9]+," rows "${serial_index}")
list(LENGTH rows run_count)
if(NOT run_count EQUAL 5)
  message(FATAL_ERROR "expected 5 runs in the index, found ${run_count}:\n${serial_index}")
endif()
file(READ ${WORK}/mpi/study.json index)
string(JSON processes GET "${index}" processes)
if(NOT processes EQUAL 2)
  message(FATAL_ERROR "the 2-rank study reports ${processes} processes")
endif()
foreach(run 0000 0001 0002 0003 0004)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/serial/runs/${run}/response.csv
                          ${WORK}/mpi/runs/${run}/response.csv RESULT_VARIABLE differ)
  if(differ)
    message(FATAL_ERROR "runs/${run}/response.csv differs between 1 process and 2 ranks")
  endif()
endforeach()
message(STATUS "2-rank study equals the serial one (5 runs)")
