# ccfr_module(NAME name [PUBLIC deps...] [PRIVATE deps...])
# One static library per folder: sources are src/*.cpp, public headers include/ccfr/<module>/*.hpp.
function(ccfr_module)
  cmake_parse_arguments(M "" "NAME" "PUBLIC;PRIVATE" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  set(_t ccfr_${M_NAME})
  add_library(${_t} ${_srcs})
  add_library(ccfr::${M_NAME} ALIAS ${_t})
  set_target_properties(${_t} PROPERTIES EXPORT_NAME ${M_NAME} POSITION_INDEPENDENT_CODE ON
                                         OUTPUT_NAME ccfr_${M_NAME})
  target_include_directories(${_t} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${_t} PUBLIC ${M_PUBLIC} PRIVATE ${M_PRIVATE})
  ccfr_warnings(${_t})
  install(TARGETS ${_t} EXPORT ccfrTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()

function(ccfr_warnings target)
  # -Wshadow=local is GCC's; the clang builds (sanitize, fuzz) go without it.
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic $<$<CXX_COMPILER_ID:GNU>:-Wshadow=local>
                                           -Wno-unused-parameter)
  # GCC 12 reports -Wrestrict on plain std::string concatenation (GCC PR 105329, a false positive).
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(CCFR_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
