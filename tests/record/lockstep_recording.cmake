# A lockstep run recorded by `tandem up --record` (the recorder is its own participant): an independent reader
# (@mcap/core + protobufjs, tests/tools/mcap/check_recording.mjs) finds every tick of both arms, and the RMS it
# recomputes from the recorded errors equals the RMS the run printed. Then `tandem report` of that recording
# opens in headless Chromium without errors, with its plots (check_report.mjs).
set(W ${WORK}/lockstep)
file(REMOVE_RECURSE ${W})
file(MAKE_DIRECTORY ${W})
file(READ ${SRC}/deploy/one-module.yaml deploy)
string(REPLACE "domain_id: 42" "domain_id: 64" deploy "${deploy}")
string(REPLACE "../config/" "${SRC}/config/" deploy "${deploy}")
file(WRITE ${W}/deploy.yaml "${deploy}")
execute_process(COMMAND ${TANDEM} up ${W}/deploy.yaml --record ${W}/run.mcap --summary ${W}/summary.txt
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tandem up --record: exit ${rc}\n${out}\n${err}")
endif()
string(FIND "${out}" "0 tick(s) missed in 0 gap(s)" pos)
if(pos EQUAL -1)
  message(FATAL_ERROR "the recorder reports missed ticks:\n${out}")
endif()
execute_process(COMMAND node ${WORK}/node/check_recording.mjs ${W}/run.mcap ${W}/summary.txt
                WORKING_DIRECTORY ${WORK}/node RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "independent check of the recording failed (${rc}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${TANDEM} report ${W}/run.mcap -o ${W}/report
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tandem report: exit ${rc}\n${out}\n${err}")
endif()
execute_process(COMMAND node ${WORK}/node/check_report.mjs ${W}/report 5
                WORKING_DIRECTORY ${WORK}/node RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the report page failed in Chromium (${rc}):\n${out}\n${err}")
endif()
