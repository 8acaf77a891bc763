# Script mode (cmake -DSRC=<checkout> -DBIN=<build dir> -DOUT=<header> -P source_revision.cmake),
# run at every build by the hs_source_revision_header target (core/revision/): writes the
# checkout's git commit, with "-dirty" when a tracked or untracked (not ignored) file differs
# from it, or "unknown" outside a git checkout. The build folder itself does not count, even
# where .gitignore does not name it. The header is rewritten only when that changes, so a
# build at the same revision recompiles nothing.
execute_process(COMMAND git -C "${SRC}" rev-parse --verify HEAD
                OUTPUT_VARIABLE rev RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT rc EQUAL 0 OR rev STREQUAL "")
  set(rev "unknown")
else()
  set(exclude "")
  file(RELATIVE_PATH bin_rel "${SRC}" "${BIN}")
  if(NOT bin_rel STREQUAL "" AND NOT bin_rel MATCHES "^\\.\\.")
    set(exclude ":(exclude)${bin_rel}")
  endif()
  execute_process(COMMAND git -C "${SRC}" status --porcelain -- . ${exclude}
                  OUTPUT_VARIABLE changes RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(NOT rc EQUAL 0)
    set(rev "${rev}-unknown-state")
  elseif(NOT changes STREQUAL "")
    set(rev "${rev}-dirty")
  endif()
endif()
set(content "// Generated at build time by cmake/source_revision.cmake; not in the repository.\n#pragma once\n#define HS_SOURCE_REVISION \"${rev}\"\n")
set(old "")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT old STREQUAL content)
  file(WRITE "${OUT}" "${content}")
endif()
