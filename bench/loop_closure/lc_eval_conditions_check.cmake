# ctest: lc_eval writes its --set assignments into its figures' conditions (cmake -P; LC_EVAL, WORK_DIR).
file(MAKE_DIRECTORY ${WORK_DIR})
execute_process(COMMAND ${LC_EVAL} --rooms 3 --seeds 1 --levels sim --tours 1 --duration 5 --json ${WORK_DIR}/lc.json
                        --set reconstruction.max_weight=50
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "lc_eval failed (${rc}): ${err}")
endif()
file(READ ${WORK_DIR}/lc.json json)
string(FIND "${json}" "loop closure on, set reconstruction.max_weight=50" at)
if(at EQUAL -1)
  message(FATAL_ERROR "the figures' conditions do not name the --set assignment")
endif()
