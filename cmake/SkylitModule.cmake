# skylit_module(name SOURCES... PUBLIC_DEPS... PRIVATE_DEPS...): one library per module, public
# headers under include/. With SKYLIT_UNITY_BUILD (the default) the module compiles as one
# translation unit: its files share their headers' parsing and template instantiations, which
# halves the libraries' compile time; file-local names must then differ across the module's files.
option(SKYLIT_UNITY_BUILD "Compile each module and each test folder as one translation unit" ON)

function(skylit_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(skylit_${name} ${ARG_SOURCES})
  add_library(skylit::${name} ALIAS skylit_${name})
  target_include_directories(skylit_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(skylit_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(skylit_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  skylit_warnings(skylit_${name})
  skylit_unity(skylit_${name})
endfunction()

# skylit_unity(target): one translation unit for the target's sources when SKYLIT_UNITY_BUILD is on.
function(skylit_unity target)
  if(NOT SKYLIT_UNITY_BUILD)
    return()
  endif()
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 0)
  # An Impl struct holding a type from its file's anonymous namespace is fine in that file alone;
  # GCC warns about it once the file is not the translation unit's main file.
  target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
endfunction()
