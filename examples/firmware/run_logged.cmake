# Runs a command with its output to a log file instead of the build log:
#   cmake -DLOG=<file> -P run_logged.cmake -- <command> [<arg>...]
# Fails (printing the log) if the command fails.
set(_cmd)
set(_after FALSE)
math(EXPR _last "${CMAKE_ARGC} - 1")
foreach(_i RANGE 1 ${_last})
  if(_after)
    list(APPEND _cmd "${CMAKE_ARGV${_i}}")
  elseif("${CMAKE_ARGV${_i}}" STREQUAL "--")
    set(_after TRUE)
  endif()
endforeach()
execute_process(COMMAND ${_cmd} RESULT_VARIABLE _rc OUTPUT_FILE "${LOG}" ERROR_FILE "${LOG}.err")
if(NOT _rc EQUAL 0)
  file(READ "${LOG}" _out)
  file(READ "${LOG}.err" _err)
  message(FATAL_ERROR "${_out}${_err}command failed (${_rc}): ${_cmd}")
endif()
