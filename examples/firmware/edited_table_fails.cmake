# A generated table header whose values were edited must not compile: its
# static_assert(table_crc(...) == crc) rejects it (ctest
# firmware_table_edited_value_fails_to_compile, host builds).
#   cmake -DHEADER=<generated header> -DCXX=<compiler> -DINCLUDES=<dir;dir> -DWORK=<dir> -P edited_table_fails.cmake
file(READ "${HEADER}" text)
# One value changed, still a valid constant expression: the tool length + 1 nm.
string(REGEX REPLACE "(// machine\\.nominal\\.tool_length\n    )([-0-9.e+]+)," "\\1\\2 + 1e-6," edited "${text}")
if(edited STREQUAL text)
  message(FATAL_ERROR "edited_table_fails: found no tool_length value to edit in ${HEADER}")
endif()
file(MAKE_DIRECTORY "${WORK}")
file(WRITE "${WORK}/edited_table.hpp" "${edited}")
file(WRITE "${WORK}/edited_table.cpp" "#include \"edited_table.hpp\"\nint main() { return 0; }\n")
set(flags)
foreach(dir IN LISTS INCLUDES)
  list(APPEND flags "-I${dir}")
endforeach()
execute_process(COMMAND "${CXX}" -std=c++17 -fsyntax-only ${flags} "${WORK}/edited_table.cpp"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(rc EQUAL 0)
  message(FATAL_ERROR "edited_table_fails: the edited table COMPILED; its CRC check did not fire")
endif()
if(NOT out MATCHES "CRC mismatch")
  message(FATAL_ERROR "edited_table_fails: failed to compile, but not on the CRC check:\n${out}")
endif()
# The unedited header compiles with the same command (so the failure is the edit's).
file(WRITE "${WORK}/edited_table.hpp" "${text}")
execute_process(COMMAND "${CXX}" -std=c++17 -fsyntax-only ${flags} "${WORK}/edited_table.cpp"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "edited_table_fails: the unedited header does not compile either:\n${out}")
endif()
message(STATUS "edited_table_fails: an edited value is rejected at compile time (CRC mismatch)")
