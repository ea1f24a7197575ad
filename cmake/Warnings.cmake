# skylit_warnings(target): the project's warning set, errors when SKYLIT_WERROR is on.
function(skylit_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                         -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough)
  if(SKYLIT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# skylit_module(name SOURCES... DEPS...): one library per module, public headers under include/.
function(skylit_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(skylit_${name} ${ARG_SOURCES})
  add_library(skylit::${name} ALIAS skylit_${name})
  target_include_directories(skylit_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(skylit_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(skylit_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  skylit_warnings(skylit_${name})
endfunction()
