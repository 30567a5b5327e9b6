# The OptiX backend is built when CUDA is available and OptiX headers are found
# through OptiX_ROOT (CMake or environment variable): the folder holding
# include/optix.h. Nothing here runs a GPU program, so it configures and compiles
# on machines without a GPU (CI does exactly that).
set(PENUMBRA_OPTIX_SUMMARY "; optix: not built")
set(PENUMBRA_HAVE_OPTIX OFF)
if(NOT PENUMBRA_OPTIX)
  set(PENUMBRA_OPTIX_SUMMARY "; optix: disabled (PENUMBRA_OPTIX=OFF)")
  return()
endif()
if(NOT OptiX_ROOT AND DEFINED ENV{OptiX_ROOT})
  set(OptiX_ROOT "$ENV{OptiX_ROOT}")
endif()
if(NOT OptiX_ROOT OR NOT EXISTS "${OptiX_ROOT}/include/optix.h")
  message(STATUS "penumbra: OptiX headers not found: set OptiX_ROOT to the folder holding include/optix.h "
                 "(e.g. -DOptiX_ROOT=$HOME/NVIDIA-OptiX-SDK-9.0.0-linux64-x86_64); the GPU backend is left out")
  set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no OptiX_ROOT)")
  return()
endif()
include(CheckLanguage)
check_language(CUDA)
if(NOT CMAKE_CUDA_COMPILER)
  message(STATUS "penumbra: no CUDA compiler found: the GPU backend is left out")
  set(PENUMBRA_OPTIX_SUMMARY "; optix: left out (no CUDA compiler)")
  return()
endif()
if(EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/src/backends/optix/CMakeLists.txt")
  add_subdirectory(src/backends/optix)
endif()
