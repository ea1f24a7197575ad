# skylit_test_suites(target): registers one CTest test per GoogleTest suite of `target`, listed
# from the built program (as gtest_discover_tests does for single tests). A suite's tests then
# share one process: every test program loads about 150 shared libraries (OpenCV's image codecs
# bring GDAL), about 0.2 s a start on the 2-core machine, and a suite's fixtures are built once.
# `ctest -R Suite` runs a suite; `bin/test_x --gtest_filter=Suite.Test` runs one test.
set(SKYLIT_LIST_SUITES_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/list_test_suites.cmake)

function(skylit_test_suites target)
  set(ctest_file ${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake)
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND ${CMAKE_COMMAND} -DPROGRAM=$<TARGET_FILE:${target}> -DCTEST_FILE=${ctest_file}
            -DWORKING_DIRECTORY=${CMAKE_CURRENT_BINARY_DIR} -P ${SKYLIT_LIST_SUITES_SCRIPT}
    BYPRODUCTS ${ctest_file}
    VERBATIM)
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${ctest_file})
endfunction()
