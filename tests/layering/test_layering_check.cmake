# The layering check must pass on a tree that keeps the rule and fail on one that breaks it, naming each of the
# seven deliberately bad includes in fixtures/bad and nothing in fixtures/good.
set(_check ${CMAKE_CURRENT_LIST_DIR}/check_layering.cmake)
set(_fixtures ${CMAKE_CURRENT_LIST_DIR}/fixtures)

execute_process(COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${_fixtures}/good -P ${_check}
                RESULT_VARIABLE _result OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
if(NOT _result EQUAL 0)
  message(FATAL_ERROR "the check refused the good fixture:\n${_out}${_err}")
endif()

execute_process(COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${_fixtures}/bad -P ${_check}
                RESULT_VARIABLE _result OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
if(_result EQUAL 0)
  message(FATAL_ERROR "the check passed the bad fixture:\n${_out}${_err}")
endif()
set(_expected
    "budgets/budget_types.h includes \"core/memory/arena.h\""
    "core/places/places.h includes \"drivers/sensor_types.h\""
    "core/places/places.h includes <firmware_app/pipeline.h>"
    "core/places/places.h includes \"bench/rooms/floor_plan_rooms.h\""
    "drivers/sim/sim_camera.cc includes \"firmware_app/runtime/pose_buffer.h\""
    "drivers/sim/sim_camera.cc includes \"tests/support/test_data.h\""
    "firmware_app/pipeline.cc includes \"bench/sim_tour.h\"")
foreach(line IN LISTS _expected)
  string(FIND "${_err}" "layering: ${line}:" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "the check did not name '${line}':\n${_err}")
  endif()
endforeach()
string(REGEX MATCHALL "layering: [^\n]* includes " _named "${_err}")
list(LENGTH _named _count)
list(LENGTH _expected _expected_count)
if(NOT _count EQUAL _expected_count)
  message(FATAL_ERROR "the check named ${_count} includes, ${_expected_count} expected:\n${_err}")
endif()
string(FIND "${_err}" "7 include(s) against the layering" _at)
if(_at EQUAL -1)
  message(FATAL_ERROR "the check's summary is missing:\n${_err}")
endif()
message(STATUS "layering check: the good fixture passes, the bad one fails on its ${_count} includes")
