# The interactive viewer, `penumbra view` (docs/viewer.md): GLFW 3, OpenGL 3.3
# core and Dear ImGui, all from Debian's packages (libglfw3-dev, libgl-dev,
# libimgui-dev). Optional: without them penumbra builds without the window and
# `penumbra view` says so in one line.
#
# Included from the top-level CMakeLists.txt after the `penumbra` target exists.
option(PENUMBRA_VIEWER "Build the interactive viewer when GLFW, OpenGL and Dear ImGui are found" ON)

# What needs no window (camera control, camera paths and the checks of the
# viewer's actions, progressive images and their tone-mapping) is always built,
# and unit-tested in tests/apps/test_viewer.cpp.
add_library(penumbra_viewer_core STATIC
  src/apps/viewer/actions_table.cpp
  src/apps/viewer/camera_control.cpp
  src/apps/viewer/camera_path.cpp
  src/apps/viewer/progressive.cpp
  src/apps/viewer/scheduler.cpp)
target_link_libraries(penumbra_viewer_core PUBLIC penumbra_lib PRIVATE penumbra_warnings)
target_sources(penumbra PRIVATE src/apps/viewer/cmd_view.cpp)
target_link_libraries(penumbra PRIVATE penumbra_viewer_core)

# The interop path's device images and kernels (device_image.h): with CUDA, that
# is where the OptiX backend is built. Needs no GL library (the CUDA runtime
# registers GL buffers through the driver); unit-tested where a GPU is present.
if(PENUMBRA_HAVE_OPTIX)
  add_library(penumbra_viewer_cuda STATIC
    src/apps/viewer/device_image.cpp
    src/apps/viewer/device_image_kernels.cu)
  target_link_libraries(penumbra_viewer_cuda PUBLIC penumbra_viewer_core CUDA::cudart_static PRIVATE penumbra_warnings)
  set_target_properties(penumbra_viewer_cuda PROPERTIES CUDA_RUNTIME_LIBRARY Static)
endif()

set(PENUMBRA_HAVE_VIEWER OFF)
set(_pn_viewer_why "")
if(NOT PENUMBRA_VIEWER)
  set(_pn_viewer_why "disabled (PENUMBRA_VIEWER=OFF)")
else()
  find_package(glfw3 3.3 QUIET)
  find_path(PENUMBRA_GL_INCLUDE_DIR GL/glcorearb.h)
  find_path(IMGUI_INCLUDE_DIR imgui.h PATH_SUFFIXES imgui)
  find_library(IMGUI_LIBRARY imgui)
  if(NOT glfw3_FOUND)
    set(_pn_viewer_why "GLFW 3.3+ not found (Debian: libglfw3-dev)")
  elseif(NOT PENUMBRA_GL_INCLUDE_DIR)
    set(_pn_viewer_why "OpenGL headers (GL/glcorearb.h) not found (Debian: libgl-dev)")
  elseif(NOT IMGUI_INCLUDE_DIR OR NOT IMGUI_LIBRARY)
    set(_pn_viewer_why "Dear ImGui not found (Debian: libimgui-dev)")
  else()
    # Debian's libimgui.a already holds the platform and renderer backends
    # (imgui_impl_glfw.o, imgui_impl_opengl3.o; headers in <imgui/backends/>);
    # it uses the system stb and dlopen()s libGL. Other packagings ship the
    # backends as sources only: then they are compiled from where they are
    # installed (never copied into this repository).
    include(CheckCXXSourceCompiles)
    set(CMAKE_REQUIRED_INCLUDES ${IMGUI_INCLUDE_DIR})
    set(CMAKE_REQUIRED_LIBRARIES ${IMGUI_LIBRARY} glfw ${STB_LIBRARY} ${CMAKE_DL_LIBS})
    set(CMAKE_REQUIRED_QUIET ON)
    check_cxx_source_compiles([[
      #include <imgui.h>
      #include <backends/imgui_impl_glfw.h>
      #include <backends/imgui_impl_opengl3.h>
      int main() { ImGui::CreateContext(); ImGui_ImplGlfw_InitForOpenGL(nullptr, true);
                   ImGui_ImplOpenGL3_Init("#version 330 core"); return 0; }]] PENUMBRA_IMGUI_HAS_BACKENDS)
    unset(CMAKE_REQUIRED_INCLUDES)
    unset(CMAKE_REQUIRED_LIBRARIES)
    unset(CMAKE_REQUIRED_QUIET)
    set(_pn_imgui_backend_sources "")
    set(_pn_imgui_how "backends from libimgui")
    if(NOT PENUMBRA_IMGUI_HAS_BACKENDS)
      find_file(PENUMBRA_IMGUI_GLFW_SOURCE imgui_impl_glfw.cpp
                PATHS ${IMGUI_INCLUDE_DIR}/backends /usr/share/imgui/backends /usr/src/imgui/backends NO_DEFAULT_PATH)
      find_file(PENUMBRA_IMGUI_OPENGL3_SOURCE imgui_impl_opengl3.cpp
                PATHS ${IMGUI_INCLUDE_DIR}/backends /usr/share/imgui/backends /usr/src/imgui/backends NO_DEFAULT_PATH)
      if(PENUMBRA_IMGUI_GLFW_SOURCE AND PENUMBRA_IMGUI_OPENGL3_SOURCE)
        set(_pn_imgui_backend_sources ${PENUMBRA_IMGUI_GLFW_SOURCE} ${PENUMBRA_IMGUI_OPENGL3_SOURCE})
        set(_pn_imgui_how "backends compiled from ${PENUMBRA_IMGUI_GLFW_SOURCE} and its sibling")
      else()
        set(_pn_viewer_why "libimgui lacks the GLFW/OpenGL 3 backends and their sources were not found")
      endif()
    endif()
    if(NOT _pn_viewer_why)
      set(PENUMBRA_HAVE_VIEWER ON)
    endif()
  endif()
endif()

if(PENUMBRA_HAVE_VIEWER)
  add_library(penumbra_viewer STATIC
    src/apps/viewer/viewer.cpp
    src/apps/viewer/images.cpp
    src/apps/viewer/actions.cpp
    src/apps/viewer/panel.cpp
    src/apps/viewer/gl_display.cpp
    src/apps/viewer/headless_gl.cpp
    ${_pn_imgui_backend_sources})
  target_include_directories(penumbra_viewer PRIVATE ${IMGUI_INCLUDE_DIR} ${PENUMBRA_GL_INCLUDE_DIR} ${STB_INCLUDE_DIR})
  # OpenGL itself is not linked: GLFW and ImGui's backend load it at run time,
  # and --headless opens libEGL.so.1 (headless_gl.cpp; its headers: libegl-dev).
  target_link_libraries(penumbra_viewer
    PUBLIC penumbra_viewer_core
    PRIVATE penumbra_warnings ${IMGUI_LIBRARY} glfw ${STB_LIBRARY} ${CMAKE_DL_LIBS})
  target_link_libraries(penumbra PRIVATE penumbra_viewer)
  set_property(SOURCE src/apps/viewer/cmd_view.cpp APPEND PROPERTY COMPILE_DEFINITIONS PENUMBRA_HAVE_VIEWER=1)
  # The CUDA-OpenGL interop display path, with the OptiX backend (CUDA found).
  if(TARGET penumbra_viewer_cuda)
    target_link_libraries(penumbra_viewer PRIVATE penumbra_viewer_cuda)
    target_compile_definitions(penumbra_viewer PRIVATE PN_VIEWER_INTEROP=1)
    set(_pn_imgui_how "${_pn_imgui_how}; display: CUDA-OpenGL interop with OptiX, else host upload")
  else()
    set(_pn_imgui_how "${_pn_imgui_how}; display: host upload (no CUDA: no interop)")
  endif()
  file(STRINGS ${IMGUI_INCLUDE_DIR}/imgui.h _pn_imgui_version REGEX "^#define IMGUI_VERSION +\"")
  string(REGEX REPLACE ".*\"(.*)\".*" "\\1" _pn_imgui_version "${_pn_imgui_version}")
  message(STATUS "penumbra: viewer: built (GLFW ${glfw3_VERSION}, Dear ImGui ${_pn_imgui_version}, ${_pn_imgui_how})")
else()
  message(STATUS "penumbra: viewer: left out: ${_pn_viewer_why}; `penumbra view` will say so")
endif()
