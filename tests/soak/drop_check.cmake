# The checker must catch a real drop: tests/soak/drop.yaml runs one module with no standby, no restart and the
# brakes off (test only); tests/soak/drop-faults.yaml kills its left robot at 8 s. The arm keeps its last
# torque and the object falls: `tandem soak` must exit 1 and report an "object held" violation after fault #1,
# between the kill and 4 s later.
file(REMOVE_RECURSE ${WORK}/drop-soak)
execute_process(COMMAND ${TANDEM} soak ${SRC}/tests/soak/drop.yaml --duration 14 --faults ${SRC}/tests/soak/drop-faults.yaml
                        --report ${WORK}/drop-soak
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}")
if(NOT rc EQUAL 1)
  message(FATAL_ERROR "tandem soak exited with ${rc} (expected 1: a violation)\nstderr: ${err}")
endif()
file(READ ${WORK}/drop-soak/summary.txt summary)
foreach(line "result=fail" "invariant.object_held=violated")
  string(FIND "${summary}" "${line}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "summary.txt lacks '${line}':\n${summary}")
  endif()
endforeach()
# violation=<t>|object held|<fault>|<text>
string(REGEX MATCH "violation=([0-9.]+)\\|object held\\|([0-9]+)\\|" m "${summary}")
if(NOT m)
  message(FATAL_ERROR "no 'object held' violation line:\n${summary}")
endif()
set(t "${CMAKE_MATCH_1}")
if(NOT CMAKE_MATCH_2 EQUAL 1)
  message(FATAL_ERROR "the drop is not attributed to fault #1: ${m}")
endif()
if(t LESS 8.0 OR t GREATER 12.0)
  message(FATAL_ERROR "the drop is reported at ${t} s, not within 4 s after the kill at 8 s")
endif()
# The drop is handled as a failure: the world fails the module (both arms braked for good), the checker counts
# it, and the launcher's log says the coordinator-less module failed.
string(FIND "${summary}" "the world reports the module failed (object dropped)" pos)
if(pos EQUAL -1)
  message(FATAL_ERROR "the drop did not fail the module:\n${summary}")
endif()
file(READ ${WORK}/drop-soak/launcher.log log)
string(FIND "${log}" "module failed:" pos)
if(pos EQUAL -1)
  message(FATAL_ERROR "the world did not say the module failed:\n${log}")
endif()
