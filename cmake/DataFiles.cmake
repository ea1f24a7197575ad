# skylit_data_files([DESTINATION SUB] FILES a b ...): files the programs read at run time
# (shaders, presets), copied at build time into share/skylit/SUB of the build tree and installed
# into share/skylit/SUB (without SUB: share/skylit), so that a program finds them beside its bin/
# folder either way (skylit/base/data_dir.hpp). A changed file is copied again by the next build.
function(skylit_data_files)
  cmake_parse_arguments(DATA "" "DESTINATION" "FILES" ${ARGN})
  set(folder "share/skylit")
  if(DATA_DESTINATION)
    string(APPEND folder "/${DATA_DESTINATION}")
  endif()
  set(copies "")
  foreach(file IN LISTS DATA_FILES)
    get_filename_component(name "${file}" NAME)
    set(copy "${CMAKE_BINARY_DIR}/${folder}/${name}")
    add_custom_command(OUTPUT "${copy}"
      COMMAND ${CMAKE_COMMAND} -E copy_if_different "${file}" "${copy}"
      DEPENDS "${file}" COMMENT "${folder}/${name}" VERBATIM)
    list(APPEND copies "${copy}")
  endforeach()
  string(MAKE_C_IDENTIFIER "skylit_data_${folder}" target)  # skylit_data_share_skylit_shaders
  add_custom_target(${target} ALL DEPENDS ${copies})
  install(FILES ${DATA_FILES} DESTINATION ${folder})
endfunction()
