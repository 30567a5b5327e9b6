# CTest test fetch_optix: how the build obtains OptiX headers when OptiX_ROOT is
# not given (cmake/FetchOptiX.cmake), without a GPU, a driver or a network. A
# local bare git repository stands in for NVIDIA's optix-dev: its tags v9.0.0
# and v9.1.0 hold a fake include/optix.h with that version's OPTIX_VERSION; the
# driver version is injected with -DPENUMBRA_NVIDIA_DRIVER_VERSION.
#
#   cmake -DSOURCE=<repo root> -DWORK=<scratch folder> [-DCUDA_COMPILER=<nvcc>] -P run.cmake
cmake_minimum_required(VERSION 3.24)
find_package(Git REQUIRED)
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

function(git)
  execute_process(COMMAND "${GIT_EXECUTABLE}" -c user.name=penumbra-test -c user.email=test@penumbra
                          -c init.defaultBranch=main -c advice.detachedHead=false ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "git ${ARGN}: ${out}${err}")
  endif()
endfunction()

# A repository laid out like optix-dev; <tags> are pairs "tag;OPTIX_VERSION".
function(make_repo name)
  set(dir "${WORK}/${name}-work")
  file(MAKE_DIRECTORY "${dir}/include")
  git(init -q "${dir}")
  set(pairs ${ARGN})
  list(LENGTH pairs n)
  math(EXPR last "${n} - 1")
  foreach(i RANGE 0 ${last} 2)
    math(EXPR j "${i} + 1")
    list(GET pairs ${i} tag)
    list(GET pairs ${j} version)
    file(WRITE "${dir}/include/optix.h" "// fake OptiX header for the fetch_optix test\n#define OPTIX_VERSION ${version}\n")
    git(-C "${dir}" add include/optix.h)
    git(-C "${dir}" commit -q -m "OptiX ${tag}")
    git(-C "${dir}" tag "${tag}")
  endforeach()
  git(clone -q --bare "${dir}" "${WORK}/${name}.git")
endfunction()

make_repo(optix-dev v9.0.0 90000 v9.1.0 90100)
make_repo(wrong v9.0.0 90100)

# Configures tests/fetch_optix in <build> with the given -D options; returns its
# "fetch_optix:" line.
function(run_fetch build out_var)
  execute_process(COMMAND "${CMAKE_COMMAND}" -S "${SOURCE}/tests/fetch_optix" -B "${WORK}/${build}" ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "configure ${build} failed:\n${out}${err}")
  endif()
  string(REGEX MATCH "fetch_optix: [^\n]*" line "${out}")
  if(NOT line OR line MATCHES ";")  # one line of text, not a CMake list
    message(FATAL_ERROR "configure ${build}: no fetch_optix line, or one with ';' in it:\n${out}")
  endif()
  message(STATUS "${build}: ${line}")
  set(${out_var} "${line}" PARENT_SCOPE)
endfunction()

function(expect line pattern what)
  if(NOT line MATCHES "${pattern}")
    message(FATAL_ERROR "${what}: expected /${pattern}/ in\n  ${line}")
  endif()
endfunction()

set(url "-DPENUMBRA_OPTIX_GIT_URL=${WORK}/optix-dev.git")

# Driver 580: OptiX 9.0 headers from tag v9.0.0.
run_fetch(b line ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=580.159.03)
expect("${line}" "tag=\\[v9.0.0\\] version=\\[90000\\] root=\\[${WORK}/b/_deps/penumbra_optix_9_0_0\\]"
       "driver 580")
if(NOT EXISTS "${WORK}/b/_deps/penumbra_optix_9_0_0/include/optix.h")
  message(FATAL_ERROR "driver 580: no include/optix.h was fetched")
endif()

# The same build folder, now for driver 590: the tag changes, so do the headers.
run_fetch(b line ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=590.44.01)
expect("${line}" "tag=\\[v9.1.0\\] version=\\[90100\\]" "driver 590 after 580")

# A later driver branch keeps the newest tag penumbra knows.
run_fetch(b610 line ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=610.2)
expect("${line}" "tag=\\[v9.1.0\\] version=\\[90100\\]" "driver 610")

# Too old a driver: nothing fetched, the reason says what to do.
run_fetch(b570 line ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=570.86)
expect("${line}" "tag=\\[\\] version=\\[\\] root=\\[\\] why=\\[NVIDIA driver 570.86 supports no OptiX 9" "driver 570")

# Offline (a repository that does not exist): one line with the command to run.
run_fetch(boff line -DPENUMBRA_OPTIX_GIT_URL=${WORK}/no-such-repo.git -DPENUMBRA_NVIDIA_DRIVER_VERSION=580.1)
expect("${line}" "root=\\[\\] why=\\[could not fetch OptiX 9.0.0 headers .*offline.*run: git clone --depth 1 --branch v9.0.0 "
                 "${WORK}/no-such-repo.git [^ ]*/.optix && cmake -DOptiX_ROOT=" "offline")

# Headers whose version is not the tag's are refused.
run_fetch(bwrong line -DPENUMBRA_OPTIX_GIT_URL=${WORK}/wrong.git -DPENUMBRA_NVIDIA_DRIVER_VERSION=580.1)
expect("${line}" "root=\\[\\] why=\\[.*OPTIX_VERSION '90100', expected 90000" "wrong headers")

# The whole project: the configure summary says where the headers came from;
# PENUMBRA_OPTIX=OFF fetches nothing.
set(project_opts -DPENUMBRA_TESTS=OFF -DPENUMBRA_VIEWER=OFF -DPENUMBRA_PYTHON=OFF)
if(CUDA_COMPILER)
  list(APPEND project_opts -DCMAKE_CUDA_COMPILER=${CUDA_COMPILER})
endif()
function(configure_project build out_var)
  # Without the OptiX_ROOT a CI run exports: the headers must come from the fetch.
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=OptiX_ROOT
                          "${CMAKE_COMMAND}" -S "${SOURCE}" -B "${WORK}/${build}" ${project_opts} ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "configure ${build} failed:\n${out}${err}")
  endif()
  string(REGEX MATCH "penumbra: backends: [^\n]*" line "${out}")
  message(STATUS "${build}: ${line}")
  set(${out_var} "${line}" PARENT_SCOPE)
endfunction()

configure_project(project-off line -DPENUMBRA_OPTIX=OFF ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=580.1)
expect("${line}" "optix: disabled \\(PENUMBRA_OPTIX=OFF\\)" "PENUMBRA_OPTIX=OFF")
if(EXISTS "${WORK}/project-off/_deps")
  message(FATAL_ERROR "PENUMBRA_OPTIX=OFF: something was fetched into ${WORK}/project-off/_deps")
endif()

if(CUDA_COMPILER)
  configure_project(project-580 line ${url} -DPENUMBRA_NVIDIA_DRIVER_VERSION=580.1)
  expect("${line}" "optix \\(OptiX 9.0.0 headers, fetched from ${WORK}/optix-dev.git at v9.0.0 for NVIDIA driver 580.1,"
         "project, driver 580")
else()
  message(STATUS "no CUDA compiler: the whole-project fetch is not checked")
endif()
message(STATUS "fetch_optix: all checks passed")
