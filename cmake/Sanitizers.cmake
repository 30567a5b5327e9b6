# The sanitizer build (issue 12): AddressSanitizer + UndefinedBehaviorSanitizer
# on everything this project compiles, and the libFuzzer targets of tests/fuzz.
# CI builds it in a second folder with Debian's clang (.ci/sanitize.sh):
#   cmake -S . -B build-asan -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DPENUMBRA_FUZZ=ON
option(PENUMBRA_SANITIZE "Compile with AddressSanitizer and UndefinedBehaviorSanitizer" OFF)
option(PENUMBRA_FUZZ "Also build the libFuzzer targets of tests/fuzz (clang; implies PENUMBRA_SANITIZE)" OFF)

if(PENUMBRA_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "PENUMBRA_FUZZ needs clang (libFuzzer): configure with -DCMAKE_CXX_COMPILER=clang++ "
                        "(Debian: clang and libclang-rt-14-dev)")
  endif()
  set(PENUMBRA_SANITIZE ON)
endif()

if(PENUMBRA_SANITIZE)
  # Any finding stops the process (no recovery), with frames to read; the fuzz
  # build also gives libFuzzer coverage feedback from the library, not only
  # from the targets. C++ only: no CUDA in this build.
  set(_pn_flags -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -g)
  if(PENUMBRA_FUZZ)
    # Less the code whose coverage follows the machine, not the input (tests/fuzz/coverage_ignore.txt).
    list(APPEND _pn_flags -fsanitize=fuzzer-no-link
         -fsanitize-coverage-ignorelist=${PROJECT_SOURCE_DIR}/tests/fuzz/coverage_ignore.txt)
  endif()
  foreach(flag ${_pn_flags})
    add_compile_options("$<$<COMPILE_LANGUAGE:CXX>:${flag}>")
  endforeach()
  add_link_options(-fsanitize=address,undefined)
  if(PENUMBRA_FUZZ)
    message(STATUS "penumbra: AddressSanitizer + UndefinedBehaviorSanitizer, libFuzzer targets (tests/fuzz)")
  else()
    message(STATUS "penumbra: AddressSanitizer + UndefinedBehaviorSanitizer")
  endif()
endif()
