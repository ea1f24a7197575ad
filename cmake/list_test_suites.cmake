# cmake -DPROGRAM=<test program> -DCTEST_FILE=<out> -DWORKING_DIRECTORY=<dir> -P list_test_suites.cmake
# Writes CTEST_FILE: one add_test per GoogleTest suite of PROGRAM (see TestSuites.cmake); a suite
# of more than kPartSize tests is split into parts of at most that many ("Suite#2of4"), so
# that `ctest -j` can spread a long suite over the cores.
set(kPartSize 8)
execute_process(COMMAND ${PROGRAM} --gtest_list_tests
                WORKING_DIRECTORY ${WORKING_DIRECTORY}
                OUTPUT_VARIABLE listing RESULT_VARIABLE status TIMEOUT 60)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} --gtest_list_tests failed (${status}):\n${listing}")
endif()
# Brackets and semicolons (in parameter dumps) would upset CMake's lists; names have none.
string(REGEX REPLACE "[][;]" "_" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")

# Suites start in the first column ("Suite." or "Prefix/Suite.  # TypeParam = ..."); their tests
# are indented ("  Test" or "  Test/param  # GetParam() = ..."); gtest_main's greeting is neither.
set(suites "")
foreach(line ${lines})
  if(line MATCHES "^[A-Za-z_][A-Za-z0-9_/]*\\.( .*)?$")
    string(REGEX REPLACE "\\..*$" "" suite "${line}")
    string(MAKE_C_IDENTIFIER "${suite}" key)
    list(APPEND suites "${suite}")
    set(tests_${key} "")
  elseif(line MATCHES "^  [A-Za-z_]" AND DEFINED key)
    string(REGEX REPLACE "^  ([^ ]+).*$" "\\1" test "${line}")
    list(APPEND tests_${key} "${suite}.${test}")
  endif()
endforeach()
if(NOT suites)
  message(FATAL_ERROR "${PROGRAM} lists no test suites:\n${listing}")
endif()

set(script "")
macro(add_part name filter)
  string(APPEND script
    "add_test([==[${name}]==] [==[${PROGRAM}]==] [==[--gtest_filter=${filter}]==])\n"
    "set_tests_properties([==[${name}]==] PROPERTIES WORKING_DIRECTORY [==[${WORKING_DIRECTORY}]==] TIMEOUT 900)\n")
endmacro()
foreach(suite ${suites})
  string(MAKE_C_IDENTIFIER "${suite}" key)
  list(LENGTH tests_${key} count)
  if(count LESS_EQUAL kPartSize)
    add_part("${suite}" "${suite}.*")
    continue()
  endif()
  math(EXPR parts "(${count} + ${kPartSize} - 1) / ${kPartSize}")
  # Spread evenly: parts of count/parts tests, the first ones one larger.
  set(first 0)
  foreach(part RANGE 1 ${parts})
    math(EXPR size "(${count} - ${first}) / (${parts} - ${part} + 1)")
    math(EXPR last "${first} + ${size} - 1")
    set(filter "")
    foreach(i RANGE ${first} ${last})
      list(GET tests_${key} ${i} test)
      string(APPEND filter "${test}:")
    endforeach()
    string(REGEX REPLACE ":$" "" filter "${filter}")
    add_part("${suite}#${part}of${parts}" "${filter}")
    math(EXPR first "${last} + 1")
  endforeach()
endforeach()
file(WRITE ${CTEST_FILE} "${script}")
