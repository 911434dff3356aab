# Runs a command that is supposed to FAIL and checks how it fails.
#   cmake [-DEXPECT_0=<regex> [-DEXPECT_1=<regex> ...]] [-DTIMEOUT=<s>]
#         -P expect_failure.cmake -- <command> [<arg>...]
# Succeeds only if <command> exits non-zero within TIMEOUT and its combined
# stdout+stderr matches every EXPECT_<n>.  Used for "heap use does not link" and
# "a fault exits instead of hanging", where a plain WILL_FAIL would also accept
# the wrong failure.
set(_cmd)
set(_after_separator FALSE)
math(EXPR _last "${CMAKE_ARGC} - 1")
foreach(_i RANGE 1 ${_last})
  if(_after_separator)
    list(APPEND _cmd "${CMAKE_ARGV${_i}}")
  elseif("${CMAKE_ARGV${_i}}" STREQUAL "--")
    set(_after_separator TRUE)
  endif()
endforeach()
if(NOT _cmd)
  message(FATAL_ERROR "expect_failure.cmake: no command given after --")
endif()
if(NOT DEFINED TIMEOUT)
  set(TIMEOUT 600)
endif()

execute_process(COMMAND ${_cmd}
  RESULT_VARIABLE _result
  OUTPUT_VARIABLE _output
  ERROR_VARIABLE _output
  TIMEOUT ${TIMEOUT})
message("${_output}")

if("${_result}" STREQUAL "0")
  message(FATAL_ERROR "expect_failure: the command SUCCEEDED but was expected to fail")
elseif(NOT "${_result}" MATCHES "^[0-9]+$")
  message(FATAL_ERROR "expect_failure: the command did not exit normally: ${_result}")
endif()
set(_n 0)
while(DEFINED EXPECT_${_n})
  if(NOT "${_output}" MATCHES "${EXPECT_${_n}}")
    message(FATAL_ERROR "expect_failure: exit status ${_result}, but output lacks /${EXPECT_${_n}}/")
  endif()
  math(EXPR _n "${_n} + 1")
endwhile()
message(STATUS "expect_failure: failed as expected (exit status ${_result}, ${_n} pattern(s) matched)")
