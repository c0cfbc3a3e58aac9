# Install layout (FHS), the CMake package (build tree and installed), the man page and the .deb.
#   bin/texdefrag                         lib/libtexdefrag.so.*        lib/texdefrag/plugins/*.so
#   lib/libtexdefrag_*_common.a (SDK)     include/texdefrag/...        lib/cmake/texdefrag/
#   share/texdefrag/{configs,plots,examples}   share/doc/texdefrag/   share/man/man1/texdefrag.1.gz
#   lib/python3/dist-packages/texdefrag/  (when the Python module is built)
# The build tree mirrors the run-time part (bin/, lib/, share/texdefrag/), so the executable finds
# its modules and configurations the same way in both (framework/include/texdefrag/util/paths.h).
include(CMakePackageConfigHelpers)

set(TEXDEFRAG_PLUGIN_ABI 1)  # = kPluginAbiVersion (framework/include/texdefrag/stage/registry.h)

# --- build tree: share/texdefrag points at the sources ----------------------------------------
file(MAKE_DIRECTORY ${CMAKE_BINARY_DIR}/share/texdefrag)
foreach(pair "configs=configs" "plots=eval/plots" "examples=examples" "python=tools/batch")
  string(REPLACE "=" ";" pair ${pair})
  list(GET pair 0 link)
  list(GET pair 1 target)
  file(CREATE_LINK ${CMAKE_SOURCE_DIR}/${target} ${CMAKE_BINARY_DIR}/share/texdefrag/${link} SYMBOLIC)
endforeach()

# --- libraries, headers, SDK -------------------------------------------------------------------
set_target_properties(texdefrag_framework PROPERTIES
  LIBRARY_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/lib EXPORT_NAME framework
  VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
install(TARGETS texdefrag_framework EXPORT texdefragTargets
        LIBRARY DESTINATION lib ARCHIVE DESTINATION lib INCLUDES DESTINATION include)
install(DIRECTORY framework/include/ DESTINATION include PATTERN testing EXCLUDE)

# Stage helper libraries (static, position-independent), with their headers.
set_target_properties(texdefrag_detectors_common PROPERTIES EXPORT_NAME detectors_common)
install(FILES plugins/detectors/common/planarity.h plugins/detectors/common/normals.h
              plugins/detectors/common/units.h plugins/detectors/common/label_io.h
              plugins/detectors/common/region_output.h plugins/detectors/common/accuracy.h
        DESTINATION include/texdefrag/detectors/common)
set_target_properties(texdefrag_packers_common PROPERTIES EXPORT_NAME packers_common)
install(DIRECTORY plugins/packers/common/include/ DESTINATION include)
set(sdk_libs texdefrag_detectors_common texdefrag_packers_common)
if(TARGET texdefrag_merge_engine)
  set_target_properties(texdefrag_merge_engine PROPERTIES EXPORT_NAME merge_engine)
  file(GLOB engine_headers ${CMAKE_SOURCE_DIR}/plugins/mergers/engine/*.h)
  list(FILTER engine_headers EXCLUDE REGEX "/test_[^/]*\\.h$")
  install(FILES ${engine_headers} DESTINATION include/texdefrag/mergers/engine)
  list(APPEND sdk_libs texdefrag_merge_engine)
endif()
install(TARGETS ${sdk_libs} EXPORT texdefragTargets ARCHIVE DESTINATION lib)

# --- the executable and stage modules: found relative to themselves -----------------------------
set_target_properties(texdefrag PROPERTIES INSTALL_RPATH "$ORIGIN/../lib")
get_property(stage_targets GLOBAL PROPERTY TEXDEFRAG_STAGE_TARGETS)
set_target_properties(${stage_targets} PROPERTIES INSTALL_RPATH "$ORIGIN/../..")

# --- CMake package: build tree (-Dtexdefrag_DIR=<build>) and installed (lib/cmake/texdefrag) ---
export(EXPORT texdefragTargets NAMESPACE texdefrag:: FILE ${CMAKE_BINARY_DIR}/texdefragTargets.cmake)
set(TEXDEFRAG_PLUGIN_DIR_FROM_PACKAGE lib/texdefrag/plugins)
configure_file(cmake/texdefragConfig.cmake.in ${CMAKE_BINARY_DIR}/texdefragConfig.cmake @ONLY)
configure_file(cmake/texdefragPlugin.cmake ${CMAKE_BINARY_DIR}/texdefragPlugin.cmake COPYONLY)
set(TEXDEFRAG_PLUGIN_DIR_FROM_PACKAGE ../../texdefrag/plugins)
configure_file(cmake/texdefragConfig.cmake.in ${CMAKE_BINARY_DIR}/cmake-install/texdefragConfig.cmake @ONLY)
write_basic_package_version_file(${CMAKE_BINARY_DIR}/texdefragConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(EXPORT texdefragTargets NAMESPACE texdefrag:: DESTINATION lib/cmake/texdefrag)
install(FILES ${CMAKE_BINARY_DIR}/cmake-install/texdefragConfig.cmake ${CMAKE_BINARY_DIR}/texdefragConfigVersion.cmake
              cmake/texdefragPlugin.cmake
        DESTINATION lib/cmake/texdefrag)

# --- data, docs, man page -----------------------------------------------------------------------
install(DIRECTORY configs/ DESTINATION share/texdefrag/configs PATTERN bad EXCLUDE)
install(FILES eval/plots/plots.py DESTINATION share/texdefrag/plots)
install(DIRECTORY examples/ DESTINATION share/texdefrag/examples)
install(FILES README.md DESTINATION share/doc/texdefrag)
install(DIRECTORY docs/ DESTINATION share/doc/texdefrag/docs)

find_program(HELP2MAN help2man)
find_program(GZIP gzip)
if(HELP2MAN AND GZIP)
  # Generated from the command's own --help and --version (Debian help2man).
  add_custom_command(OUTPUT ${CMAKE_BINARY_DIR}/man/texdefrag.1.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_BINARY_DIR}/man
    COMMAND ${HELP2MAN} --no-info --no-discard-stderr --section=1
            "--name=texture defragmentation of photogrammetric 3D building models" --include=${CMAKE_SOURCE_DIR}/cmake/texdefrag.h2m
            --output=${CMAKE_BINARY_DIR}/man/texdefrag.1 $<TARGET_FILE:texdefrag>
    COMMAND ${GZIP} -9nf ${CMAKE_BINARY_DIR}/man/texdefrag.1
    DEPENDS texdefrag ${CMAKE_SOURCE_DIR}/cmake/texdefrag.h2m
    COMMENT "help2man: texdefrag.1" VERBATIM)
  add_custom_target(texdefrag_man ALL DEPENDS ${CMAKE_BINARY_DIR}/man/texdefrag.1.gz)
  install(FILES ${CMAKE_BINARY_DIR}/man/texdefrag.1.gz DESTINATION share/man/man1)
else()
  message(STATUS "help2man or gzip not found: no man page (scripts/install-deps.sh installs help2man)")
endif()

# --- the .deb (cpack -G DEB in the build folder; scripts/package.sh) -----------------------------
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME texdefrag)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "texdefrag")
set(CPACK_PACKAGE_CONTACT "texdefrag maintainers <texdefrag@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "texture defragmentation of photogrammetric 3D building models")
set(CPACK_PACKAGE_DESCRIPTION "texdefrag reads a textured mesh (OBJ + MTL + pages) and writes the same
geometry with fewer, larger charts packed into a smaller atlas (Liu et al. 2024; the M-method).
Includes the stage SDK (headers, helper libraries, CMake package) and the Python module.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # dpkg-shlibdeps: Debian 12's runtime libraries
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS usr/lib)  # libtexdefrag.so is in this package
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(TEXDEFRAG_DEB_EXTRA_DEPENDS "" CACHE STRING "Depends added to dpkg-shlibdeps' (comma-separated)")
set(deb_depends ${TEXDEFRAG_DEB_EXTRA_DEPENDS} ${TEXDEFRAG_PYTHON_DEB_DEPENDS})  # python/CMakeLists.txt
list(JOIN deb_depends ", " CPACK_DEBIAN_PACKAGE_DEPENDS)
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "libeigen3-dev, nlohmann-json3-dev, libopenmesh-dev, cmake, g++, python3-matplotlib")
include(CPack)
