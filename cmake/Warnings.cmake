# skylit_warnings(target): the project's warning set, errors when SKYLIT_WERROR is on.
function(skylit_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                         -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough)
  if(SKYLIT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
