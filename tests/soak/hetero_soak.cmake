# The heterogeneous soak: deploy/soak-hetero.yaml (a 3R + cartesian PPR module and a 3R + redundant 4R module, with
# standbys) in lockstep (`--timing lockstep`: the soak's timing wins over the file's) for 60 s under the `ci` preset
# with a fixed seed. Every invariant must hold (exit 0, summary.txt result=pass), progress among them (every module in
# service does a task at least every 45 s), and robots, worlds and stalls must have been carried out.
file(REMOVE_RECURSE ${WORK}/hetero-soak)
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${TANDEM} soak ${SRC}/deploy/soak-hetero.yaml --timing lockstep --duration 60 --faults ci --seed 5
                        --report ${WORK}/hetero-soak
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tandem soak exited with ${rc} (expected 0)\nstderr: ${err}")
endif()
file(READ ${WORK}/hetero-soak/summary.txt summary)
foreach(line "result=pass" "invariant.object_held=held" "invariant.recovery=held" "invariant.tasks_exactly_once=held"
             "invariant.nothing_left_behind=held" "invariant.progress=held"
             "invariant.tasks_held_throughout=held")
  string(FIND "${summary}" "${line}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "summary.txt lacks '${line}':\n${summary}")
  endif()
endforeach()
foreach(kind kill_robot kill_world stall_robot)
  string(REGEX MATCH "faults\\.${kind}=([0-9]+)" m "${summary}")
  if(NOT m OR CMAKE_MATCH_1 LESS 1)
    message(FATAL_ERROR "no '${kind}' fault was carried out:\n${summary}")
  endif()
endforeach()
