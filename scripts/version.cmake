# Writes OUT (a header defining OBLONG_VERSION from `git describe` of SRC, and
# OBLONG_VERSION_NUMBER from NUMBER, the project's version); rewrites it
# only when the version changed, so that an unchanged tree rebuilds nothing.
execute_process(COMMAND git -C "${SRC}" describe --always --dirty --abbrev=12
                OUTPUT_VARIABLE v OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR v STREQUAL "")
  set(v "unknown (not a git checkout)")
endif()
set(text "#define OBLONG_VERSION \"${v}\"\n#define OBLONG_VERSION_NUMBER \"${NUMBER}\"\n")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT "${old}" STREQUAL "${text}")
  file(WRITE "${OUT}" "${text}")
endif()
