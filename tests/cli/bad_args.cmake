# Every `tandem` command's command line (CLI11): --help exits 0 and shows the command's usage; an unknown option
# exits 2 and names it; bad values of the live commands exit 2 with a message naming what was wrong, before
# anything is sent (no deployment runs: a command that got past its checks would wait 10 s for a launcher).
set(deploy ${SRC}/deploy/one-module.yaml)
foreach(cmd sim up soak record report view keys agent status down kill plug unplug)
  execute_process(COMMAND ${TANDEM} ${cmd} --help RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 20)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "Usage: tandem ${cmd} ")
    message(FATAL_ERROR "tandem ${cmd} --help: exit ${rc}, no usage line:\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${TANDEM} ${cmd} ${deploy} --frobnicate RESULT_VARIABLE rc ERROR_VARIABLE err TIMEOUT 20)
  string(FIND "${err}" "'--frobnicate'" pos)
  if(NOT rc EQUAL 2 OR pos EQUAL -1)
    message(FATAL_ERROR "tandem ${cmd} --frobnicate: expected exit 2 naming the option, got ${rc}: ${err}")
  endif()
endforeach()
set(cases
  "kill|${deploy}|name one process"
  "kill|-|give a deployment file, or --domain ID"
  "plug|${deploy},robot|expected 'robot <label>' or 'module <name>'"
  "plug|${deploy},robot,m1|a robot is named <module>/<arm>"
  "plug|${deploy},robot,m1/left,--scenario,x.yaml|place a module, not a robot"
  "plug|${deploy},robot,m1/left,--standby,--primary|exclude each other"
  "plug|${deploy},module,m2,--standby|apply to a robot, not a module"
  "plug|${deploy},module,m2,--scenario,x.yaml|give both --scenario FILE and --case NAME"
  "unplug|${deploy},module,a/b|a module name has no '/'"
  "status|--domain,300|--domain: Value 300 not in range 0 to 232"
  "status|${deploy},--domain,010|not a whole number in decimal"
  "view|${deploy},--port,080|not a port number"
  "down|${deploy},extra|unexpected 'extra'"
  "up|-|deploy is required"
  "agent|${deploy}|--host is required"
  "soak|${deploy},--duration,0|expected a time above 0")
foreach(c IN LISTS cases)
  string(REPLACE "|" ";" parts "${c}")
  list(GET parts 0 cmd)
  list(GET parts 1 args)
  list(GET parts 2 expect)
  string(REPLACE "," ";" args "${args}")
  if(args STREQUAL "-")
    set(args "")
  endif()
  execute_process(COMMAND ${TANDEM} ${cmd} ${args} RESULT_VARIABLE rc ERROR_VARIABLE err TIMEOUT 20)
  string(FIND "${err}" "${expect}" pos)
  if(NOT rc EQUAL 2 OR pos EQUAL -1)
    message(FATAL_ERROR "tandem ${cmd} ${args}: expected exit 2 and '${expect}', got ${rc}: ${err}")
  endif()
endforeach()
