# Functions for building FricHB plugins, shared by the source tree and by installed packages
# (find_package(FricHB) includes this file).
#
# Inputs (set before including): FRICHB_SDK_TARGET (the SDK target), FRICHB_CONFORMANCE_COMMAND
# (the frichb-conformance executable or target), and optionally FRICHB_PLUGIN_OUTPUT_DIR (where
# plugins are built), FRICHB_PLUGIN_INSTALL_DIR (where they install) and
# FRICHB_PLUGIN_EXTRA_LIBS.

# frichb_add_plugin(<target> SOURCES <src>... [LIBRARIES <lib>...]): a plugin shared library
# (MODULE, no "lib" prefix, hidden visibility) written against the SDK.
function(frichb_add_plugin target)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  add_library(${target} MODULE ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${FRICHB_SDK_TARGET} ${FRICHB_PLUGIN_EXTRA_LIBS}
                        ${ARG_LIBRARIES})
  target_compile_features(${target} PRIVATE cxx_std_17)
  set_target_properties(${target} PROPERTIES
    PREFIX ""
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  if(FRICHB_PLUGIN_OUTPUT_DIR)
    set_target_properties(${target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${FRICHB_PLUGIN_OUTPUT_DIR})
  endif()
  if(FRICHB_PLUGIN_INSTALL_DIR)
    install(TARGETS ${target} LIBRARY DESTINATION ${FRICHB_PLUGIN_INSTALL_DIR})
  endif()
endfunction()

# frichb_add_conformance_test(<plugin target> [NAME <suffix>] [PARAMS "<yaml map>"]
#                             [ARGS <runner options>...]): a ctest `conformance_<suffix>`
# running the conformance kit on the plugin through the real loader.
function(frichb_add_conformance_test target)
  cmake_parse_arguments(ARG "" "NAME;PARAMS" "ARGS" ${ARGN})
  if(NOT ARG_PARAMS)
    set(ARG_PARAMS "{}")
  endif()
  if(NOT ARG_NAME)
    set(ARG_NAME ${target})
  endif()
  add_test(NAME conformance_${ARG_NAME}
           COMMAND ${FRICHB_CONFORMANCE_COMMAND} $<TARGET_FILE:${target}> --params "${ARG_PARAMS}"
                   ${ARG_ARGS})
  set_tests_properties(conformance_${ARG_NAME} PROPERTIES LABELS "unit;conformance")
endfunction()
