# The layering rule, checked on every build (cmake -DSOURCE_DIR=<tree> -P check_layering.cmake): each folder below
# may not include a header from the folders listed after it. budgets/ is the bottom (the tables and their types),
# core/ pure libraries, drivers/ devices and simulators over core's messages, firmware_app/ the shell; bench/, tests/
# and fuzz/ sit on top and may include anything. Fails (exit status 1) naming every offending file and include.
# It also checks the size limits on core/ (check_sizes.cmake: files of at most 1,000 lines, functions of 150).
cmake_minimum_required(VERSION 3.16)  # the policies of the project (check_sizes.cmake keeps empty lines)
if(NOT SOURCE_DIR)
  message(FATAL_ERROR "check_layering.cmake: set -DSOURCE_DIR=<source tree>")
endif()

set(_forbidden_budgets core drivers firmware_app bench tests fuzz)
set(_forbidden_core drivers firmware_app bench tests fuzz)
set(_forbidden_drivers firmware_app bench tests fuzz)
set(_forbidden_firmware_app bench tests fuzz)

set(_violations 0)
set(_scanned 0)
foreach(layer budgets core drivers firmware_app)
  list(JOIN _forbidden_${layer} "|" _alternatives)
  # An #include of <above>/... in quotes or angle brackets, after optional blanks.
  set(_pattern "^[ \t]*#[ \t]*include[ \t]*[<\"](${_alternatives})/[^\">]*[\">]")
  file(GLOB_RECURSE _files LIST_DIRECTORIES false RELATIVE ${SOURCE_DIR}
       ${SOURCE_DIR}/${layer}/*.h ${SOURCE_DIR}/${layer}/*.hpp ${SOURCE_DIR}/${layer}/*.cc ${SOURCE_DIR}/${layer}/*.cpp
       ${SOURCE_DIR}/${layer}/*.c ${SOURCE_DIR}/${layer}/*.inc)
  foreach(file IN LISTS _files)
    math(EXPR _scanned "${_scanned} + 1")
    file(STRINGS ${SOURCE_DIR}/${file} _lines REGEX "${_pattern}")
    foreach(line IN LISTS _lines)
      string(REGEX MATCH "[<\"][^\">]*[\">]" _header "${line}")
      list(JOIN _forbidden_${layer} "/, " _names)
      message("layering: ${file} includes ${_header}: ${layer}/ may not include ${_names}/")
      math(EXPR _violations "${_violations} + 1")
    endforeach()
  endforeach()
endforeach()

# The size limits on core/ (issue 32): no file over 1,000 lines, no function over 150 (check_sizes.cmake).
include(${CMAKE_CURRENT_LIST_DIR}/check_sizes.cmake)

if(_scanned EQUAL 0)
  message(FATAL_ERROR "layering: no source file under ${SOURCE_DIR}/{budgets,core,drivers,firmware_app}")
endif()
if(_violations GREATER 0)
  message(FATAL_ERROR "layering: ${_violations} include(s) against the layering in ${SOURCE_DIR} (tests/layering)")
endif()
if(_size_violations GREATER 0)
  message(FATAL_ERROR "size: ${_size_violations} file(s) or function(s) in ${SOURCE_DIR}/core over the limits (tests/layering)")
endif()
