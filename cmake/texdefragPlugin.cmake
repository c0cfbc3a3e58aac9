# texdefrag_add_plugin(NAME target SOURCES ... [LIBS ...])
# One out-of-tree stage module: a MODULE library named exactly `target`.so (no "lib" prefix),
# hidden symbols but the TEXDEFRAG_PLUGIN entry point, linked to texdefrag::framework and LIBS.
# Load it with TEXDEFRAG_PLUGIN_PATH=<folder of the .so>, or install it into TEXDEFRAG_PLUGIN_DIR.
function(texdefrag_add_plugin)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_NAME OR NOT ARG_SOURCES)
    message(FATAL_ERROR "texdefrag_add_plugin: NAME and SOURCES are required")
  endif()
  add_library(${ARG_NAME} MODULE ${ARG_SOURCES})
  target_compile_features(${ARG_NAME} PRIVATE cxx_std_17)
  target_link_libraries(${ARG_NAME} PRIVATE texdefrag::framework ${ARG_LIBS})
  set_target_properties(${ARG_NAME} PROPERTIES PREFIX "" CXX_VISIBILITY_PRESET hidden
                                               POSITION_INDEPENDENT_CODE ON)
endfunction()
