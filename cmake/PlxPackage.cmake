# `cmake --install`: the parallax program, every module's static library and public headers,
# and a CMake package, so that another project links the installed modules by
# find_package(Parallax) as it would link them from the source tree (README, "Using the library
# from CMake"). tests/install builds such a project against an installed tree.
include(CMakePackageConfigHelpers)

set(PLX_PACKAGE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Parallax)
install(EXPORT ParallaxTargets NAMESPACE plx:: DESTINATION ${PLX_PACKAGE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/ParallaxConfig.cmake.in
    ${PROJECT_BINARY_DIR}/ParallaxConfig.cmake INSTALL_DESTINATION ${PLX_PACKAGE_DIR})
# Before 1.0 a minor version may change the interfaces; only the same major.minor matches.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ParallaxConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/ParallaxConfig.cmake
              ${PROJECT_BINARY_DIR}/ParallaxConfigVersion.cmake
    DESTINATION ${PLX_PACKAGE_DIR})
