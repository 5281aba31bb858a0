# Generates budgets/budget_table.h from every board table (budgets/*.json), with one board selected as active.
#
#   cmake -DTABLES="a.json;b.json" -DACTIVE=host_sim -DOUT=.../budget_table.h -P generate_budget_header.cmake
#
# Runs on the build host (also when cross-compiling) and needs nothing but CMake >= 3.19 (string(JSON)).
# A malformed table stops the build with a message naming the file and the field.
cmake_minimum_required(VERSION 3.19)

foreach(var TABLES ACTIVE OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "generate_budget_header: -D${var}=... is required")
  endif()
endforeach()

# snake_case -> kCamelCase
function(to_constant out name)
  string(REGEX REPLACE "[^A-Za-z0-9]+" "_" name "${name}")
  string(REPLACE "_" ";" parts "${name}")
  set(result "k")
  foreach(p IN LISTS parts)
    if(p STREQUAL "")
      continue()
    endif()
    string(SUBSTRING "${p}" 0 1 first)
    string(SUBSTRING "${p}" 1 -1 rest)
    string(TOUPPER "${first}" first)
    string(APPEND result "${first}${rest}")
  endforeach()
  set(${out} "${result}" PARENT_SCOPE)
endfunction()

function(check_identifier file what name)
  if(NOT name MATCHES "^[a-z][a-z0-9_]*$")
    message(FATAL_ERROR "${file}: ${what} '${name}' must be snake_case ([a-z][a-z0-9_]*)")
  endif()
endfunction()

# Reads json member path into out; fails with the file and path when absent or of the wrong kind.
function(json_get out file json kind)
  string(JSON value ERROR_VARIABLE err GET "${json}" ${ARGN})
  if(err)
    string(REPLACE ";" "." path "${ARGN}")
    message(FATAL_ERROR "${file}: field '${path}' is missing or malformed (${err})")
  endif()
  string(JSON type ERROR_VARIABLE err TYPE "${json}" ${ARGN})
  string(REPLACE ";" "." path "${ARGN}")
  if(kind STREQUAL "uint")
    if(NOT type STREQUAL "NUMBER" OR NOT value MATCHES "^[0-9]+$")
      message(FATAL_ERROR "${file}: field '${path}' must be a non-negative integer, got '${value}'")
    endif()
  elseif(kind STREQUAL "number")
    if(NOT type STREQUAL "NUMBER" OR NOT value MATCHES "^[0-9]+(\\.[0-9]+)?$")
      message(FATAL_ERROR "${file}: field '${path}' must be a non-negative number, got '${value}'")
    endif()
  elseif(kind STREQUAL "string")
    if(NOT type STREQUAL "STRING")
      message(FATAL_ERROR "${file}: field '${path}' must be a string")
    endif()
    string(REPLACE "\\" "\\\\" value "${value}")
    string(REPLACE "\"" "\\\"" value "${value}")
  elseif(kind STREQUAL "object")
    if(NOT type STREQUAL "OBJECT")
      message(FATAL_ERROR "${file}: field '${path}' must be an object")
    endif()
  endif()
  set(${out} "${value}" PARENT_SCOPE)
endfunction()

function(json_has out json)
  string(JSON value ERROR_VARIABLE err GET "${json}" ${ARGN})
  if(err)
    set(${out} FALSE PARENT_SCOPE)
  else()
    set(${out} TRUE PARENT_SCOPE)
  endif()
endfunction()

function(json_keys out file json)
  json_get(obj "${file}" "${json}" object ${ARGN})
  string(JSON n LENGTH "${json}" ${ARGN})
  set(keys "")
  if(n GREATER 0)
    math(EXPR last "${n} - 1")
    foreach(i RANGE ${last})
      string(JSON k MEMBER "${json}" ${ARGN} ${i})
      list(APPEND keys "${k}")
    endforeach()
  endif()
  set(${out} "${keys}" PARENT_SCOPE)
endfunction()

set(body "")
set(boards "")
foreach(file IN LISTS TABLES)
  file(READ "${file}" json)
  string(JSON probe ERROR_VARIABLE err TYPE "${json}")
  if(err)
    message(FATAL_ERROR "${file}: not valid JSON (${err})")
  endif()
  json_get(board "${file}" "${json}" string board)
  check_identifier("${file}" "board" "${board}")
  get_filename_component(stem "${file}" NAME_WE)
  if(NOT stem STREQUAL board)
    message(FATAL_ERROR "${file}: board '${board}' must match the file name '${stem}.json'")
  endif()
  json_get(description "${file}" "${json}" string description)
  list(APPEND boards "${board}")

  set(ns "")
  set(arena_rows "")
  set(cap_rows "")
  json_keys(arenas "${file}" "${json}" arenas)
  foreach(arena IN LISTS arenas)
    check_identifier("${file}" "arena" "${arena}")
    json_get(bytes "${file}" "${json}" uint arenas ${arena} bytes)
    string(APPEND ns "namespace ${arena} {\ninline constexpr std::size_t kArenaBytes = ${bytes}ULL;\n")
    string(APPEND arena_rows "    {\"${arena}\", ${bytes}ULL},\n")
    json_keys(caps "${file}" "${json}" arenas ${arena} capacities)
    foreach(cap IN LISTS caps)
      check_identifier("${file}" "capacity" "${cap}")
      json_get(value "${file}" "${json}" uint arenas ${arena} capacities ${cap})
      to_constant(c "${cap}")
      string(APPEND ns "inline constexpr std::size_t ${c} = ${value}ULL;\n")
      string(APPEND cap_rows "    {\"${arena}\", \"${cap}\", ${value}ULL},\n")
    endforeach()
    string(APPEND ns "}  // namespace ${arena}\n")
  endforeach()

  set(task_rows "")
  string(APPEND ns "namespace tasks {\n")
  json_keys(tasks "${file}" "${json}" tasks)
  foreach(task IN LISTS tasks)
    check_identifier("${file}" "task" "${task}")
    json_has(has_rate "${json}" tasks ${task} rate_hz)
    json_has(has_div "${json}" tasks ${task} every_n_keyframes)
    set(rate 0)
    set(div 0)
    set(offset 0)
    if(has_rate AND has_div)
      message(FATAL_ERROR "${file}: task '${task}' has both rate_hz and every_n_keyframes; give one")
    elseif(has_rate)
      json_get(rate "${file}" "${json}" number tasks ${task} rate_hz)
    elseif(has_div)
      json_get(div "${file}" "${json}" uint tasks ${task} every_n_keyframes)
      json_get(offset "${file}" "${json}" uint tasks ${task} offset)
    endif()
    json_has(has_budget "${json}" tasks ${task} budget_us)
    set(budget 0)
    if(has_budget)
      json_get(budget "${file}" "${json}" uint tasks ${task} budget_us)
    endif()
    json_get(prio "${file}" "${json}" uint tasks ${task} priority)
    string(APPEND ns "namespace ${task} {\ninline constexpr double kRateHz = ${rate};\n"
      "inline constexpr std::uint32_t kEveryNKeyframes = ${div};\ninline constexpr std::uint32_t kOffset = ${offset};\n"
      "inline constexpr std::uint32_t kBudgetUs = ${budget};\ninline constexpr std::uint32_t kPriority = ${prio};\n"
      "}  // namespace ${task}\n")
    string(APPEND task_rows "    {\"${task}\", ${rate}, ${div}, ${offset}, ${budget}, ${prio}},\n")
  endforeach()
  string(APPEND ns "}  // namespace tasks\n")

  set(queue_rows "")
  string(APPEND ns "namespace queues {\n")
  json_keys(queues "${file}" "${json}" queues)
  foreach(queue IN LISTS queues)
    check_identifier("${file}" "queue" "${queue}")
    json_get(depth "${file}" "${json}" uint queues ${queue} depth)
    json_get(policy "${file}" "${json}" string queues ${queue} policy)
    # Optional: how long a consumer may wait for an element before it gives up (0: it does not wait).
    json_has(has_wait "${json}" queues ${queue} max_wait_us)
    set(wait 0)
    if(has_wait)
      json_get(wait "${file}" "${json}" uint queues ${queue} max_wait_us)
    endif()
    if(policy STREQUAL "drop_oldest")
      set(p kDropOldest)
    elseif(policy STREQUAL "drop_newest")
      set(p kDropNewest)
    elseif(policy STREQUAL "collate")
      set(p kCollate)
    else()
      message(FATAL_ERROR "${file}: queue '${queue}' has policy '${policy}'; use drop_oldest, drop_newest or collate")
    endif()
    string(APPEND ns "namespace ${queue} {\ninline constexpr std::uint32_t kDepth = ${depth};\n"
      "inline constexpr DropPolicy kPolicy = DropPolicy::${p};\n"
      "inline constexpr std::uint32_t kMaxWaitUs = ${wait};\n}  // namespace ${queue}\n")
    string(APPEND queue_rows "    {\"${queue}\", ${depth}, DropPolicy::${p}, ${wait}},\n")
  endforeach()
  string(APPEND ns "}  // namespace queues\n")

  # Worker threads outside the tick loop: a per-run CPU budget, and optionally a rate in keyframes.
  set(thread_rows "")
  string(APPEND ns "namespace threads {\n")
  json_keys(threads "${file}" "${json}" threads)
  if(NOT threads)
    message(FATAL_ERROR "${file}: 'threads' must list the worker threads (segmentation, backend)")
  endif()
  foreach(thread IN LISTS threads)
    check_identifier("${file}" "thread" "${thread}")
    json_get(tbudget "${file}" "${json}" uint threads ${thread} budget_us)
    json_has(has_every "${json}" threads ${thread} every_n_keyframes)
    set(every 0)
    if(has_every)
      json_get(every "${file}" "${json}" uint threads ${thread} every_n_keyframes)
    endif()
    # Optional parts of a thread's work with their own budget (0: none): a pass that runs inside some of its runs,
    # and the one run at the end of a mission.
    set(part_budget 0)
    json_has(has_part "${json}" threads ${thread} part_budget_us)
    if(has_part)
      json_get(part_budget "${file}" "${json}" uint threads ${thread} part_budget_us)
    endif()
    set(finish_budget 0)
    json_has(has_finish "${json}" threads ${thread} finish_budget_us)
    if(has_finish)
      json_get(finish_budget "${file}" "${json}" uint threads ${thread} finish_budget_us)
    endif()
    set(solve_budget 0)
    json_has(has_solve "${json}" threads ${thread} solve_budget_us)
    if(has_solve)
      json_get(solve_budget "${file}" "${json}" uint threads ${thread} solve_budget_us)
    endif()
    string(APPEND ns "namespace ${thread} {\ninline constexpr std::uint32_t kBudgetUs = ${tbudget};\n"
      "inline constexpr std::uint32_t kEveryNKeyframes = ${every};\n"
      "inline constexpr std::uint32_t kPartBudgetUs = ${part_budget};\n"
      "inline constexpr std::uint32_t kFinishBudgetUs = ${finish_budget};\n"
      "inline constexpr std::uint32_t kSolveBudgetUs = ${solve_budget};\n}  // namespace ${thread}\n")
    string(APPEND thread_rows
      "    {\"${thread}\", ${tbudget}, ${every}, ${part_budget}, ${finish_budget}, ${solve_budget}},\n")
  endforeach()
  string(APPEND ns "}  // namespace threads\n")

  string(APPEND body
    "// ---- ${board}: generated from ${file}\n"
    "namespace qsg::budgets::${board} {\n"
    "inline constexpr char kBoard[] = \"${board}\";\n"
    "${ns}"
    "inline constexpr ArenaBudget kArenas[] = {\n${arena_rows}};\n"
    "inline constexpr CapacityBudget kCapacities[] = {\n${cap_rows}};\n"
    "inline constexpr TaskBudget kTasks[] = {\n${task_rows}};\n"
    "inline constexpr QueueBudget kQueues[] = {\n${queue_rows}};\n"
    "inline constexpr ThreadBudget kThreads[] = {\n${thread_rows}};\n"
    "inline constexpr BoardTable kTable = {kBoard, \"${description}\", kArenas, std::size(kArenas), kCapacities,\n"
    "    std::size(kCapacities), kTasks, std::size(kTasks), kQueues, std::size(kQueues), kThreads, std::size(kThreads)};\n"
    "}  // namespace qsg::budgets::${board}\n\n")
endforeach()

if(NOT ACTIVE IN_LIST boards)
  message(FATAL_ERROR "QSG_BOARD='${ACTIVE}' has no table in budgets/ (have: ${boards})")
endif()
set(all_rows "")
foreach(b IN LISTS boards)
  string(APPEND all_rows "&${b}::kTable, ")
endforeach()

set(content "// GENERATED by budgets/generate_budget_header.cmake from budgets/*.json. Do not edit: edit the tables.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iterator>

#include \"budgets/budget_types.h\"

${body}namespace qsg::budgets {
// The board this build was configured for (CMake QSG_BOARD).
namespace active = ${ACTIVE};
inline constexpr const BoardTable* kAllBoards[] = {${all_rows}};
}  // namespace qsg::budgets
")

# Write only on change, so unchanged tables do not rebuild everything.
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
  if(old STREQUAL content)
    return()
  endif()
endif()
file(WRITE "${OUT}" "${content}")
