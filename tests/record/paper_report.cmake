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
string(REGEX REPLACE "^case\\.SOSM\\.1\\.ep_pos_rms=" "" recomputed "${line}")
if(printed STREQUAL "" OR recomputed STREQUAL "")
  message(FATAL_ERROR "could not read the SOSM RMS (printed '${printed}', report '${line}')\n${sim_out}")
endif()
# CMake has no floats: node compares, within the printed precision (5 significant digits).
execute_process(COMMAND node -e "const [a, b] = [Number(process.argv[1]), Number(process.argv[2])]; process.exit(Math.abs(a - b) <= 1e-4 * Math.abs(b) ? 0 : 1)"
                        ${recomputed} ${printed} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "SOSM right e_p RMS: recomputed from the recording ${recomputed}, tandem sim printed ${printed}")
endif()
execute_process(COMMAND node ${WORK}/node/check_report.mjs ${W}/report 28
                WORKING_DIRECTORY ${WORK}/node RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the paper report failed in Chromium (${rc}):\n${out}\n${err}")
endif()
