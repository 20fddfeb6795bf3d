# Installs the independent checkers' npm packages (@mcap/core, protobufjs, playwright-core, ws; pinned by
# tests/tools/mcap/package-lock.json) into WORK/node, once per lock file. Needs node and npm (scripts/test.sh
# installs them) and the npm registry.
file(MAKE_DIRECTORY ${WORK}/node)
file(READ ${SRC}/tests/tools/mcap/package-lock.json want)
set(have "")
if(EXISTS ${WORK}/node/package-lock.json AND EXISTS ${WORK}/node/node_modules/@mcap/core)
  file(READ ${WORK}/node/package-lock.json have)
endif()
foreach(f package.json package-lock.json check_recording.mjs check_report.mjs)
  configure_file(${SRC}/tests/tools/mcap/${f} ${WORK}/node/${f} COPYONLY)
endforeach()
foreach(f foxglove_client.mjs check_view_page.mjs check_view_replay.mjs)  # tandem view's checkers, on the same packages
  configure_file(${SRC}/tests/tools/view/${f} ${WORK}/node/${f} COPYONLY)
endforeach()
if(NOT have STREQUAL want)
  execute_process(COMMAND npm ci --no-audit --no-fund --loglevel=error WORKING_DIRECTORY ${WORK}/node
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "npm ci failed (${rc}): needs node, npm and the npm registry\n${out}\n${err}")
  endif()
endif()
message(STATUS "checkers ready in ${WORK}/node")
