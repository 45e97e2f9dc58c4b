# Writes the build's identity (the version everywhere, issue 26) into OUT from TEMPLATE, at every build:
#   cmake -DSOURCE_DIR=... -DTEMPLATE=... -DOUT=... -DRELEASE=0.1.0 -DBUILD_TYPE=Release [-DGIT_FALLBACK=...] -P build_info.cmake
# The git description is `git describe --always --dirty` of SOURCE_DIR; without git or without a .git
# (a source tarball) it is GIT_FALLBACK, or "unknown (no git)". configure_file rewrites OUT only when
# its text changed, so an unchanged tree recompiles nothing.
set(EMADIAG_GIT_DESCRIPTION "")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS "${SOURCE_DIR}/.git")
  execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE_DIR}" describe --always --dirty
                  OUTPUT_VARIABLE EMADIAG_GIT_DESCRIPTION OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE git_rc ERROR_QUIET)
  if(NOT git_rc EQUAL 0)
    set(EMADIAG_GIT_DESCRIPTION "")
  endif()
endif()
if(EMADIAG_GIT_DESCRIPTION STREQUAL "")
  if(GIT_FALLBACK)
    set(EMADIAG_GIT_DESCRIPTION "${GIT_FALLBACK}")
  else()
    set(EMADIAG_GIT_DESCRIPTION "unknown (no git)")
  endif()
endif()
set(EMADIAG_RELEASE "${RELEASE}")
set(EMADIAG_BUILD_TYPE "${BUILD_TYPE}")
if(EMADIAG_BUILD_TYPE STREQUAL "")
  set(EMADIAG_BUILD_TYPE "none")
endif()
configure_file("${TEMPLATE}" "${OUT}" @ONLY)
