# coneshadow --version: the project version and, in a git checkout, the revision it was configured at
# (the build reconfigures when HEAD moves, so the revision stays current).
set(CONESHADOW_GIT_REVISION "")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS "${CMAKE_SOURCE_DIR}/.git")
  execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${CMAKE_SOURCE_DIR}" rev-parse --short=10 HEAD
                  OUTPUT_VARIABLE CONESHADOW_GIT_REVISION OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  foreach(f HEAD logs/HEAD)
    if(EXISTS "${CMAKE_SOURCE_DIR}/.git/${f}")
      set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${CMAKE_SOURCE_DIR}/.git/${f}")
    endif()
  endforeach()
endif()
