# cmake -DPROGRAM=EXE -DHELP2MAN=PATH -DOUT=PAGE.1.gz -P ManPage.cmake: the manual page of one
# program, made by help2man from its --help and --version, its NAME line the first line of
# --help ("skylit-bake: basis shadow images ..."), gzipped without a timestamp (lintian's rule).
execute_process(COMMAND "${PROGRAM}" --help OUTPUT_VARIABLE help RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} --help failed (${status})")
endif()
string(REGEX MATCH "^[^:\n]*: ([^\n]*)" first_line "${help}")
get_filename_component(program "${PROGRAM}" NAME)
set(summary "${CMAKE_MATCH_1}")
if(summary STREQUAL "")
  set(summary "${program}")
endif()
string(REGEX REPLACE "\\.gz$" "" page "${OUT}")
execute_process(COMMAND "${HELP2MAN}" --no-info --section=1 --source=skylit "--name=${summary}"
                        "--output=${page}" "${PROGRAM}" RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "help2man failed on ${PROGRAM} (${status})")
endif()
execute_process(COMMAND gzip -9nf "${page}" RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "gzip failed on ${page}")
endif()
