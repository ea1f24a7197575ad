# skylit_shared_pch(NAME HEADERS h... LIBS l... [DEFINITIONS d...] [OPTIONS o...]): one precompiled header that
# many targets reuse (skylit_use_shared_pch), so that gtest, Eigen, OpenCV, JSON and CLI11 are
# parsed once per build instead of once per file. A target that reuses it gets the same libraries
# (their include paths and definitions must match for GCC to accept the header; where they do not,
# GCC quietly parses the headers as usual).
set(SKYLIT_PCH_SOURCE ${CMAKE_CURRENT_LIST_DIR}/pch_source.cpp)

function(skylit_shared_pch name)
  cmake_parse_arguments(ARG "" "" "HEADERS;LIBS;DEFINITIONS;OPTIONS" ${ARGN})
  add_library(${name} OBJECT ${SKYLIT_PCH_SOURCE})
  target_link_libraries(${name} PUBLIC ${ARG_LIBS})
  target_compile_definitions(${name} PUBLIC ${ARG_DEFINITIONS})
  skylit_warnings(${name})
  target_compile_options(${name} PUBLIC ${ARG_OPTIONS})
  target_precompile_headers(${name} PRIVATE ${ARG_HEADERS})
endfunction()

function(skylit_use_shared_pch target name)
  target_link_libraries(${target} PRIVATE ${name})
  target_precompile_headers(${target} REUSE_FROM ${name})
endfunction()
