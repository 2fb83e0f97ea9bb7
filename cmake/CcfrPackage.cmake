include(CMakePackageConfigHelpers)
set(_cfgdir ${CMAKE_INSTALL_LIBDIR}/cmake/ccfr)
install(EXPORT ccfrTargets NAMESPACE ccfr:: DESTINATION ${_cfgdir})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/ccfrConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/ccfrConfig.cmake INSTALL_DESTINATION ${_cfgdir})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/ccfrConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/ccfrConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/ccfrConfigVersion.cmake
        DESTINATION ${_cfgdir})
