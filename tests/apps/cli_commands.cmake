# The executable's top level: --version, and a command that does not exist
# (a usage error, exit status 2, with the nearest command where one is close).
function(run expect_rc)
  execute_process(COMMAND ${PENUMBRA} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expect_rc)
    message(FATAL_ERROR "penumbra ${ARGN}: exit status ${rc}, expected ${expect_rc}\n${out}${err}")
  endif()
  set(OUT "${out}" PARENT_SCOPE)
  set(ERR "${err}" PARENT_SCOPE)
endfunction()

# --version: the project's version, and where in git it was built from (git describe), on stdout.
run(0 --version)
string(REPLACE "." "\\." version_re "${VERSION}")
if(NOT OUT MATCHES "^penumbra ${version_re}( \\(([0-9A-Za-z._-]+)\\))?\n$" OR NOT ERR STREQUAL "")
  message(FATAL_ERROR "penumbra --version: expected 'penumbra ${VERSION} (<git describe>)', got:\n${OUT}${ERR}")
endif()
set(describe "${CMAKE_MATCH_2}")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS ${SOURCE}/.git)
  # A commit of this checkout: the last part of `git describe` (after "-g" where a tag precedes it).
  string(REGEX REPLACE "-dirty$" "" commit "${describe}")
  string(REGEX REPLACE "^.*-g([0-9a-f]+)$" "\\1" commit "${commit}")
  execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --verify --quiet "${commit}^{commit}"
                  WORKING_DIRECTORY ${SOURCE} RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
  if(describe STREQUAL "" OR NOT rc EQUAL 0)
    message(FATAL_ERROR "penumbra --version does not name a commit of ${SOURCE}: '${OUT}'")
  endif()
endif()

# A mistyped command: one line naming it and the command meant, exit status 2, nothing on stdout.
foreach(pair "rendr:render" "comapre:compare" "converg:converge" "scene:scenes" "bnech:bench")
  string(REPLACE ":" ";" pair "${pair}")
  list(GET pair 0 typed)
  list(GET pair 1 meant)
  run(2 ${typed} cornell-sphere --spp 0)
  if(NOT ERR STREQUAL "penumbra: error: unknown command '${typed}' (did you mean '${meant}'?)\n" OR
     NOT OUT STREQUAL "")
    message(FATAL_ERROR "penumbra ${typed}: expected one line suggesting '${meant}', got:\n${OUT}${ERR}")
  endif()
endforeach()
# Nothing close: the commands there are.
run(2 xyzzy)
if(NOT ERR STREQUAL
   "penumbra: error: unknown command 'xyzzy' (commands: render, scenes, compare, converge, bench, view)\n")
  message(FATAL_ERROR "penumbra xyzzy: expected one line listing the commands, got:\n${ERR}")
endif()
# No command at all is a usage error too; --help and real commands are not taken for unknown ones.
run(2)
string(FIND "${ERR}" "A subcommand is required" pos)
if(pos EQUAL -1)
  message(FATAL_ERROR "penumbra without a command: ${ERR}")
endif()
run(0 --help)
run(0 --help-all)
run(0 scenes)
