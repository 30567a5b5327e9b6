# OptiX headers for the NVIDIA driver of this machine, fetched at configure time
# from NVIDIA's public optix-dev repository (headers only; none are kept in this
# repository). Used by OptiXBackend.cmake when OptiX_ROOT is not given, and by
# the CTest test fetch_optix (tests/fetch_optix/), which runs it against a fake
# repository and fake driver versions.
#
# Nothing here runs GPU code: the driver version is read from
# /proc/driver/nvidia/version, else from `nvidia-smi --query-gpu=driver_version`.
#
# Cache variables:
#   PENUMBRA_OPTIX_GIT_URL          where the headers come from: NVIDIA's repository by
#                                   default; a mirror, or a local clone (bare or not)
#   PENUMBRA_NVIDIA_DRIVER_VERSION  the driver version to match instead of the detected
#                                   one (tests; building for another machine)
#
#   penumbra_optix_tag_for_driver(<tag_var> <driver_var> <why_var>)
#     <driver_var>: the driver version found ("" if none); <tag_var>: the optix-dev
#     tag whose OptiX ABI that driver supports, or "" with the reason in <why_var>.
#   penumbra_fetch_optix_headers(<tag> <root_var> <why_var>)
#     Fetches <tag> with FetchContent and sets <root_var> to the folder holding
#     include/optix.h, or to "" with one line in <why_var> (offline: the command to
#     run instead; headers whose OPTIX_VERSION is not the tag's).

set(PENUMBRA_OPTIX_GIT_URL "https://github.com/NVIDIA/optix-dev.git" CACHE STRING
    "Git repository of the OptiX headers fetched when OptiX_ROOT is not set (a mirror or local clone works too)")
set(PENUMBRA_NVIDIA_DRIVER_VERSION "" CACHE STRING
    "NVIDIA driver version whose OptiX headers are fetched (default: the installed driver's)")

# The installed driver's version (e.g. 580.159.03), or "".
function(penumbra_detect_nvidia_driver out_var)
  set(version "")
  if(EXISTS "/proc/driver/nvidia/version")
    # "NVRM version: NVIDIA UNIX x86_64 Kernel Module  580.159.03  Thu ..." (or "Open Kernel
    # Module for x86_64  580.159.03  Release Build ..."): the first dotted number on the line.
    file(STRINGS "/proc/driver/nvidia/version" lines REGEX "^NVRM version")
    if(lines)
      list(GET lines 0 line)
      if(line MATCHES "[ \t]([0-9]+\\.[0-9]+(\\.[0-9]+)?)([ \t]|$)")
        set(version "${CMAKE_MATCH_1}")
      endif()
    endif()
  endif()
  if(NOT version)
    find_program(PENUMBRA_NVIDIA_SMI nvidia-smi)
    mark_as_advanced(PENUMBRA_NVIDIA_SMI)
    if(PENUMBRA_NVIDIA_SMI)
      execute_process(COMMAND "${PENUMBRA_NVIDIA_SMI}" --query-gpu=driver_version --format=csv,noheader
                      OUTPUT_VARIABLE out RESULT_VARIABLE rc ERROR_QUIET TIMEOUT 30)
      if(rc EQUAL 0 AND out MATCHES "^[ \t\n]*([0-9]+\\.[0-9]+(\\.[0-9]+)?)")
        set(version "${CMAKE_MATCH_1}")
      endif()
    endif()
  endif()
  set(${out_var} "${version}" PARENT_SCOPE)
endfunction()

function(penumbra_optix_tag_for_driver tag_var driver_var why_var)
  set(tag "")
  set(why "")
  set(driver "${PENUMBRA_NVIDIA_DRIVER_VERSION}")
  if(NOT driver)
    penumbra_detect_nvidia_driver(driver)
  endif()
  if(NOT driver)
    set(why "no OptiX_ROOT and no NVIDIA driver found")
  elseif(NOT driver MATCHES "^([0-9]+)(\\.[0-9]+)*$")
    set(why "NVIDIA driver version '${driver}' is not a version number")
  else()
    set(major "${CMAKE_MATCH_1}")
    # The newest OptiX each driver branch supports (OptiX release notes): penumbra
    # needs OptiX 9.
    if(major GREATER_EQUAL 590)
      set(tag "v9.1.0")
    elseif(major GREATER_EQUAL 580)
      set(tag "v9.0.0")
    else()
      string(CONCAT why "NVIDIA driver ${driver} supports no OptiX 9 (driver 580 or later does): update the "
                        "driver, or set OptiX_ROOT to OptiX 9 headers to compile the GPU backend anyway")
    endif()
  endif()
  set(${tag_var} "${tag}" PARENT_SCOPE)
  set(${driver_var} "${driver}" PARENT_SCOPE)
  set(${why_var} "${why}" PARENT_SCOPE)
endfunction()

# OPTIX_VERSION of the headers under <root> (e.g. 90000), or "".
function(penumbra_optix_header_version root out_var)
  set(v "")
  if(EXISTS "${root}/include/optix.h")
    file(STRINGS "${root}/include/optix.h" line REGEX "^#define OPTIX_VERSION [0-9]+")
    if(line MATCHES "^#define OPTIX_VERSION ([0-9]+)")
      set(v "${CMAKE_MATCH_1}")
    endif()
  endif()
  set(${out_var} "${v}" PARENT_SCOPE)
endfunction()

function(penumbra_fetch_optix_headers tag root_var why_var)
  set(${root_var} "" PARENT_SCOPE)
  string(REGEX REPLACE "^v([0-9]+)\\.([0-9]+)\\.([0-9]+)$" "\\1;\\2;\\3" parts "${tag}")
  list(GET parts 0 major)
  list(GET parts 1 minor)
  list(GET parts 2 micro)
  math(EXPR expected "${major} * 10000 + ${minor} * 100 + ${micro}")
  set(url "${PENUMBRA_OPTIX_GIT_URL}")
  # One FetchContent name and folder per tag: a new driver's tag is a fresh clone.
  set(name "penumbra_optix_${major}_${minor}_${micro}")
  set(src "${CMAKE_BINARY_DIR}/_deps/${name}")

  # Offline, FetchContent would stop the configure; ask the repository first
  # (unless this tag is already here) and, if it does not answer, say what to run.
  penumbra_optix_header_version("${src}" have)
  if(NOT have STREQUAL expected)
    find_package(Git QUIET)
    set(rc 1)
    if(GIT_EXECUTABLE)
      execute_process(COMMAND "${GIT_EXECUTABLE}" ls-remote --tags "${url}" "refs/tags/${tag}"
                      OUTPUT_VARIABLE refs RESULT_VARIABLE rc ERROR_QUIET TIMEOUT 60)
    endif()
    if(NOT rc EQUAL 0 OR NOT refs MATCHES "refs/tags/${tag}")
      string(CONCAT why "could not fetch OptiX ${major}.${minor}.${micro} headers (tag ${tag}) from ${url} "
                        "(offline?). To build the GPU backend, run: git clone --depth 1 --branch ${tag} ${url} "
                        "${CMAKE_SOURCE_DIR}/.optix && cmake -DOptiX_ROOT=${CMAKE_SOURCE_DIR}/.optix ${CMAKE_BINARY_DIR}")
      set(${why_var} "${why}" PARENT_SCOPE)
      return()
    endif()
  endif()

  include(FetchContent)
  # Populated once per tag: reconfiguring does not go back to the network.
  string(TOUPPER "${name}" uname)
  set(FETCHCONTENT_UPDATES_DISCONNECTED_${uname} ON)
  FetchContent_Declare(${name}
    GIT_REPOSITORY "${url}"
    GIT_TAG "${tag}"
    GIT_SHALLOW TRUE
    SOURCE_DIR "${src}")
  # The repository has no CMakeLists.txt: this only populates the folder.
  FetchContent_MakeAvailable(${name})

  penumbra_optix_header_version("${src}" got)
  if(NOT got STREQUAL expected)
    set(${why_var} "${url} at ${tag}: include/optix.h has OPTIX_VERSION '${got}', expected ${expected}" PARENT_SCOPE)
    return()
  endif()
  set(${root_var} "${src}" PARENT_SCOPE)
  set(${why_var} "" PARENT_SCOPE)
endfunction()
