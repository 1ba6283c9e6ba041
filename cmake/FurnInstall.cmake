# `cmake --install build [--prefix P]` (docs/building.md, "Installing"):
#   P/bin/workbench
#   P/lib/libfurnidet.so.0 and P/include/furnidet/furnidet.h
#   P/lib/cmake/furnidet/  find_package(furnidet) -> furnidet::furnidet
#   P/lib/pkgconfig/furnidet.pc
#   P/share/furnidet/data/ class_map.json, tuning spaces, the real set's labels
#   P/lib/python3.X/dist-packages/furnidet/  the Python package (import furnidet)
# Nothing installed names the build or source folder: the programs find the
# data beside themselves (core/util/data_dir.h), the pkg-config file its
# prefix from where it lies, the CMake config from where it lies.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
set(FURN_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/furnidet/data)
set(FURN_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/furnidet)

install(TARGETS workbench RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS furnidet EXPORT furnidetTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(FILES ${PROJECT_SOURCE_DIR}/workbench/api/furnidet.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/furnidet)
install(EXPORT furnidetTargets NAMESPACE furnidet:: DESTINATION ${FURN_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/furnidetConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/furnidetConfig.cmake
                              INSTALL_DESTINATION ${FURN_INSTALL_CMAKEDIR}
                              PATH_VARS FURN_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/furnidetConfigVersion.cmake
                                 COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/furnidetConfig.cmake
              ${PROJECT_BINARY_DIR}/furnidetConfigVersion.cmake
        DESTINATION ${FURN_INSTALL_CMAKEDIR})
configure_file(${PROJECT_SOURCE_DIR}/cmake/furnidet.pc.in ${PROJECT_BINARY_DIR}/furnidet.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/furnidet.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/ DESTINATION ${FURN_INSTALL_DATADIR})

if(FURN_BUILD_PYTHON)
  # Debian's python3 looks in /usr/local/lib/python3.X/dist-packages (the
  # default prefix); for --prefix /usr, Debian's own is lib/python3/dist-packages.
  set(FURN_PYTHON_INSTALL_DIR
      ${CMAKE_INSTALL_LIBDIR}/python${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}/dist-packages
      CACHE STRING "Where the furnidet Python package goes, relative to the install prefix")
  install(TARGETS _furnidet LIBRARY DESTINATION ${FURN_PYTHON_INSTALL_DIR}/furnidet)
  install(FILES ${PROJECT_SOURCE_DIR}/workbench/python/furnidet/__init__.py
          DESTINATION ${FURN_PYTHON_INSTALL_DIR}/furnidet)
endif()
