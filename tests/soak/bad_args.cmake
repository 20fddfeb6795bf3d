# Bad arguments and schedule files: exit code 2, a message naming what was wrong and what is accepted, and
# nothing started (no report directory).
file(REMOVE_RECURSE ${WORK}/bad-soak)
file(MAKE_DIRECTORY ${WORK}/bad-soak)
file(WRITE ${WORK}/bad-soak/typo.yaml "faults:\n  - {kind: kill, target: robot, rate: 2, ofen: 1}\n")
file(WRITE ${WORK}/bad-soak/target.yaml "faults:\n  - {kind: unplug, target: world, rate: 1}\n")
set(cases
  "--duration|10x|'10x': expected a time above 0"
  "--seed|-3|expected a whole number"
  "--timing|fast|accepted: realtime, lockstep"
  "--transport|tcp|accepted: udp, shm"
  "--faults|gentle|presets: mixed, ci, kills, none"
  "--faults|${WORK}/bad-soak/typo.yaml|unknown key 'ofen'"
  "--faults|${WORK}/bad-soak/target.yaml|accepted: robot, standby, module"
  "--frobnicate|-|unknown option or extra argument '--frobnicate'")
foreach(c IN LISTS cases)
  string(REPLACE "|" ";" parts "${c}")
  list(GET parts 0 opt)
  list(GET parts 1 val)
  list(GET parts 2 expect)
  set(cmd ${TANDEM} soak ${SRC}/deploy/soak-small.yaml ${opt})
  if(NOT val STREQUAL "-")
    list(APPEND cmd ${val})
  endif()
  execute_process(COMMAND ${cmd} --report ${WORK}/bad-soak/report WORKING_DIRECTORY ${WORK}/bad-soak
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "'${opt} ${val}': expected exit 2, got ${rc}\n${out}\n${err}")
  endif()
  string(FIND "${err}" "${expect}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "'${opt} ${val}': message lacks '${expect}': ${err}")
  endif()
  if(EXISTS ${WORK}/bad-soak/report)
    message(FATAL_ERROR "'${opt} ${val}': a refused soak must not create its report directory")
  endif()
endforeach()
# A missing deployment file.
execute_process(COMMAND ${TANDEM} soak ${WORK}/bad-soak/none.yaml RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "missing deployment: expected exit 2, got ${rc}: ${err}")
endif()
# No deployment, --judge of a directory with no recording, and both at once.
foreach(c "|a deployment file is required" "--judge;${WORK}/bad-soak|cannot open ${WORK}/bad-soak/history.pb"
          "${SRC}/deploy/soak-small.yaml;--judge;${WORK}/bad-soak|excludes --judge"
          "--judge;${WORK}/bad-soak;--seed;3|--judge excludes --seed")
  string(REPLACE "|" ";" parts "${c}")
  list(LENGTH parts n)
  math(EXPR last "${n} - 1")
  list(GET parts ${last} expect)
  list(REMOVE_AT parts ${last})
  execute_process(COMMAND ${TANDEM} soak ${parts} RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "'soak ${parts}': expected exit 2, got ${rc}: ${err}")
  endif()
  string(FIND "${err}" "${expect}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "'soak ${parts}': message lacks '${expect}': ${err}")
  endif()
endforeach()
# --print-schedule: the same seed prints the same schedule, and nothing starts.
execute_process(COMMAND ${TANDEM} soak ${SRC}/deploy/soak-small.yaml --duration 90 --seed 5 --faults ci --print-schedule
                OUTPUT_VARIABLE a RESULT_VARIABLE rca)
execute_process(COMMAND ${TANDEM} soak ${SRC}/deploy/soak-small.yaml --duration 90 --seed 5 --faults ci --print-schedule
                OUTPUT_VARIABLE b)
if(NOT rca EQUAL 0 OR NOT a STREQUAL b OR NOT a MATCHES "kind: kill")
  message(FATAL_ERROR "--print-schedule: not the same schedule twice (rc ${rca}):\n${a}\n---\n${b}")
endif()
