# Run at every build (daemon/CMakeLists.txt, target rutd_git_commit): writes OUT, a header with the git
# commit of SOURCE_DIR and whether the checkout has changes not committed, so that `rutd --version` and the
# RutSoftwareVersion CAN message name what was built even when nothing was reconfigured since the last
# commit. OUT is rewritten only when that changes, so an unchanged checkout recompiles nothing. A tree
# without git (a source archive, a machine without the git program) builds too and says so.
#   cmake -DSOURCE_DIR=... -DOUT=... -P git_commit.cmake
cmake_minimum_required(VERSION 3.22)  # the policies of the project
set(commit "")
set(modified 0)
find_program(GIT_PROGRAM git)
if(GIT_PROGRAM)
  # Only SOURCE_DIR's own checkout counts: a source archive unpacked inside another repository (a packaging
  # repository, say) must not report that repository's commit.
  execute_process(COMMAND ${GIT_PROGRAM} -C ${SOURCE_DIR} rev-parse --show-toplevel
                  RESULT_VARIABLE status OUTPUT_VARIABLE top OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  file(REAL_PATH "${SOURCE_DIR}" source_dir)
  if(status EQUAL 0)
    file(REAL_PATH "${top}" top)
  endif()
  set(head "")
  if(status EQUAL 0 AND top STREQUAL source_dir)
    execute_process(COMMAND ${GIT_PROGRAM} -C ${SOURCE_DIR} rev-parse --verify --quiet HEAD
                    RESULT_VARIABLE status OUTPUT_VARIABLE head OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  endif()
  if(status EQUAL 0 AND head MATCHES "^[0-9a-f]+$")
    set(commit ${head})
    # --no-optional-locks: never take the index lock while someone runs git in the same checkout.
    # Untracked files that are not ignored count: the build lists its sources, but a new file is a change.
    execute_process(COMMAND ${GIT_PROGRAM} --no-optional-locks -C ${SOURCE_DIR} status --porcelain
                    RESULT_VARIABLE status OUTPUT_VARIABLE changes ERROR_QUIET)
    if(NOT status EQUAL 0 OR NOT changes STREQUAL "")
      set(modified 1)
    endif()
  endif()
endif()
file(CONFIGURE OUTPUT ${OUT} @ONLY CONTENT "#pragma once
// Generated at build time by daemon/git_commit.cmake: the commit this build was made from.
#define RUTD_GIT_COMMIT \"@commit@\"  // empty: not built from a git checkout
#define RUTD_GIT_MODIFIED @modified@
")
