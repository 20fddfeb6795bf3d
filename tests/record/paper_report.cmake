# `tandem sim` of the paper scenario writes an MCAP recording; `tandem report` makes the paper's figures for
# every case side by side (4 figures x 7 cases); the page opens in headless Chromium without errors; the RMS
# the report recomputes from the recording equals what `tandem sim` printed (SOSM, right robot).
set(W ${WORK}/paper)
file(REMOVE_RECURSE ${W})
file(MAKE_DIRECTORY ${W})
execute_process(COMMAND ${TANDEM} sim ${SRC}/config/scenarios/paper.yaml --no-csv --out ${W} --mcap ${W}/paper.mcap
                RESULT_VARIABLE rc OUTPUT_VARIABLE sim_out ERROR_VARIABLE err TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tandem sim: exit ${rc}\n${sim_out}\n${err}")
endif()
execute_process(COMMAND ${TANDEM} report ${W}/paper.mcap -o ${W}/report
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tandem report: exit ${rc}\n${out}\n${err}")
endif()
# SOSM, right robot: the sim's table prints e_p pos RMS with 5 digits; the report recomputes it from the samples.
string(REGEX MATCH "SOSM +left[^\n]*\n +right +[0-9.e+-]+ +([0-9.e+-]+)" m "${sim_out}")
set(printed ${CMAKE_MATCH_1})
file(STRINGS ${W}/report/summary.txt line REGEX "^case\\.SOSM\\.1\\.ep_pos_rms=")
string(REGEX REPLACE "^case\\.SOSM\\.1\\.ep_pos_rms=([0-9.]+)e-05.*" "\\1" mantissa "${line}")
string(REGEX REPLACE "^([0-9.]+)e-05$" "\\1" printed_mantissa "${printed}")
if(printed STREQUAL "" OR mantissa STREQUAL "")
  message(FATAL_ERROR "could not read the SOSM RMS (printed '${printed}', report '${line}')\n${sim_out}")
endif()
# CMake has no floats: compare the first 4 digits of the mantissas
string(SUBSTRING "${mantissa}" 0 5 m4)
string(SUBSTRING "${printed_mantissa}" 0 5 p4)
if(NOT m4 STREQUAL p4)
  message(FATAL_ERROR "SOSM right e_p RMS: report ${line}, tandem sim printed ${printed}")
endif()
execute_process(COMMAND node ${WORK}/node/check_report.mjs ${W}/report 28
                WORKING_DIRECTORY ${WORK}/node RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the paper report failed in Chromium (${rc}):\n${out}\n${err}")
endif()
