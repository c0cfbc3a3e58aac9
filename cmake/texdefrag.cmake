# texdefrag_add_stage(NAME kind.name SOURCES ... [LIBS ...])
# Builds one stage as a run-time loadable module in the build's plugin folder. The name must be
# `detectors|mergers|packers` . lower_snake_case; the module file is texdefrag_<kind>_<name>.so.
function(texdefrag_add_stage)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_NAME MATCHES "^(detectors|mergers|packers)\\.[a-z][a-z0-9_]*$")
    message(FATAL_ERROR "texdefrag_add_stage: malformed stage name '${ARG_NAME}' "
                        "(expected detectors|mergers|packers.lower_snake_case)")
  endif()
  string(REPLACE "." "_" target "texdefrag_${ARG_NAME}")
  add_library(${target} MODULE ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE texdefrag::framework ${ARG_LIBS})
  set_target_properties(${target} PROPERTIES PREFIX "" LIBRARY_OUTPUT_DIRECTORY ${TEXDEFRAG_PLUGIN_BUILD_DIR}
                                             CXX_VISIBILITY_PRESET hidden)
  install(TARGETS ${target} LIBRARY DESTINATION lib/texdefrag/plugins)
  set_property(GLOBAL APPEND PROPERTY TEXDEFRAG_STAGE_TARGETS ${target})
endfunction()

# texdefrag_add_test(NAME name SOURCES ... [LIBS ...] [LABELS ...] [TIMEOUT s])
# A GoogleTest executable registered with ctest; it depends on every stage module so tests can
# create stages by name.
function(texdefrag_add_test)
  cmake_parse_arguments(ARG "" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT TEXDEFRAG_BUILD_TESTS)
    return()
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE texdefrag::framework texdefrag::testing ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  set(labels ${ARG_LABELS})
  if(NOT labels)
    set(labels unit)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  add_test(NAME ${ARG_NAME} COMMAND ${ARG_NAME})
  set_tests_properties(${ARG_NAME} PROPERTIES LABELS "${labels}" TIMEOUT ${ARG_TIMEOUT})
  set_property(GLOBAL APPEND PROPERTY TEXDEFRAG_TEST_TARGETS ${ARG_NAME})
endfunction()
