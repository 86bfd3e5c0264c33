# Fails when docs/scene-reference.md differs from what `frichb reference` generates now.
execute_process(COMMAND ${EXE} reference -o ${OUT} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "frichb reference failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/scene-reference.md ${DOC}
                RESULT_VARIABLE differs)
if(differs)
  message(FATAL_ERROR "docs/scene-reference.md is out of date: run "
                      "`build/bin/frichb reference -o docs` and commit the result")
endif()
