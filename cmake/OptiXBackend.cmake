# The OptiX backend is built when CUDA is available and OptiX headers are found:
# OptiX_ROOT (CMake or environment variable), the folder holding include/optix.h,
# or, when it is not given and an NVIDIA driver is installed, headers matching
# that driver fetched from NVIDIA's optix-dev repository (cmake/FetchOptiX.cmake:
# driver 580 -> OptiX 9.0, 590 and later -> 9.1). Nothing here runs a GPU
# program, so it configures and compiles on machines without a GPU (CI does
# exactly that, with the headers that .ci/optix_headers.sh unpacks from PyPI).
#
# Included from the top-level CMakeLists.txt (not add_subdirectory) so that the
# CUDA language is enabled in the top directory, as CMake requires.
set(PENUMBRA_OPTIX_SUMMARY "; optix: not built")
set(PENUMBRA_HAVE_OPTIX OFF)
if(NOT PENUMBRA_OPTIX)
  set(PENUMBRA_OPTIX_SUMMARY "; optix: disabled (PENUMBRA_OPTIX=OFF)")
  return()
endif()
if(NOT EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/src/backends/optix/CMakeLists.txt")
  set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no sources)")
  return()
endif()
if(NOT OptiX_ROOT AND DEFINED ENV{OptiX_ROOT})
  # Cached: a later reconfigure (e.g. by `cmake --build`) without the variable keeps it.
  set(OptiX_ROOT "$ENV{OptiX_ROOT}" CACHE PATH "Folder holding include/optix.h (from the environment)")
endif()
set(_pn_optix_origin "")
set(_pn_optix_tag "")
if(OptiX_ROOT)
  if(NOT EXISTS "${OptiX_ROOT}/include/optix.h")
    message(STATUS "penumbra: OptiX_ROOT=${OptiX_ROOT} has no include/optix.h: set OptiX_ROOT to the folder holding "
                   "include/optix.h (e.g. -DOptiX_ROOT=$HOME/NVIDIA-OptiX-SDK-9.0.0-linux64-x86_64); "
                   "the GPU backend is left out")
    set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no include/optix.h in OptiX_ROOT)")
    return()
  endif()
else()
  # No headers given: those of the installed driver, if there is one.
  include(${CMAKE_CURRENT_LIST_DIR}/FetchOptiX.cmake)
  penumbra_optix_tag_for_driver(_pn_optix_tag _pn_driver _pn_why)
  if(NOT _pn_optix_tag)
    message(STATUS "penumbra: ${_pn_why}: the GPU backend is left out (set OptiX_ROOT to the folder holding "
                   "include/optix.h to build it anyway)")
    set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (${_pn_why})")
    return()
  endif()
endif()

# The CUDA compiler: CUDACXX, nvcc on the PATH, else CUDA's default install folder.
if(NOT DEFINED ENV{CUDACXX} AND NOT CMAKE_CUDA_COMPILER)
  find_program(PENUMBRA_NVCC nvcc)
  mark_as_advanced(PENUMBRA_NVCC)
  if(NOT PENUMBRA_NVCC AND EXISTS "/usr/local/cuda/bin/nvcc")
    set(ENV{CUDACXX} "/usr/local/cuda/bin/nvcc")
  endif()
endif()
include(CheckLanguage)
check_language(CUDA)
if(NOT CMAKE_CUDA_COMPILER)
  message(STATUS "penumbra: no CUDA compiler found (nvcc: install the CUDA toolkit, 12 or later): "
                 "the GPU backend is left out")
  set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no CUDA compiler)")
  return()
endif()

if(_pn_optix_tag)
  penumbra_fetch_optix_headers(${_pn_optix_tag} OptiX_ROOT _pn_why)
  if(NOT OptiX_ROOT)
    message(STATUS "penumbra: ${_pn_why}")
    set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no OptiX headers: see above)")
    return()
  endif()
  set(_pn_optix_origin ", fetched from ${PENUMBRA_OPTIX_GIT_URL} at ${_pn_optix_tag} for NVIDIA driver ${_pn_driver}")
endif()

# GPU architectures. Nothing here may depend on a GPU being present, so no
# "native": the default is Hopper machine code (the project's benchmark GPU)
# plus Turing PTX that the driver compiles for any newer GPU. Override with
# -DCMAKE_CUDA_ARCHITECTURES=... (e.g. 89 for an RTX 40xx).
if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES AND NOT DEFINED ENV{CUDAARCHS})
  set(CMAKE_CUDA_ARCHITECTURES "75-virtual;90-real" CACHE STRING "CUDA architectures (penumbra default)")
endif()
enable_language(CUDA)
find_package(CUDAToolkit REQUIRED)

# OptiX version from the headers, for messages.
file(STRINGS "${OptiX_ROOT}/include/optix.h" _pn_optix_version_line REGEX "^#define OPTIX_VERSION [0-9]+")
string(REGEX REPLACE "^#define OPTIX_VERSION ([0-9]+).*" "\\1" _pn_optix_version "${_pn_optix_version_line}")
math(EXPR _pn_optix_major "${_pn_optix_version} / 10000")
math(EXPR _pn_optix_minor "(${_pn_optix_version} % 10000) / 100")
math(EXPR _pn_optix_micro "${_pn_optix_version} % 100")
set(PENUMBRA_OPTIX_VERSION_STRING "${_pn_optix_major}.${_pn_optix_minor}.${_pn_optix_micro}")

add_subdirectory(src/backends/optix)
add_subdirectory(src/backends/cuda)  # the trace stage's cuda traversal and `bench --probe`
add_subdirectory(src/backends/wavefront)  # the wavefront path tracer's GPU driver (--wavefront)

target_link_libraries(penumbra_lib PUBLIC penumbra_optix penumbra_cuda_trace penumbra_wavefront)
target_compile_definitions(penumbra_lib PUBLIC PN_HAVE_OPTIX=1 PN_HAVE_CUDA_TRACE=1)
set(PENUMBRA_HAVE_OPTIX ON)
set(PENUMBRA_OPTIX_SUMMARY
    "; optix (OptiX ${PENUMBRA_OPTIX_VERSION_STRING} headers${_pn_optix_origin}, CUDA ${CMAKE_CUDA_COMPILER_VERSION}, architectures ${CMAKE_CUDA_ARCHITECTURES})")
