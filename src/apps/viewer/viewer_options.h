// What `penumbra view` is asked to do (cmd_view.cpp fills it from the command
// line; viewer.h's run_viewer takes it).
#pragma once

#include <string>
#include <vector>

#include "render/backend.h"

namespace pn::viewer {

struct ViewerOptions {
  std::string scene;                // built-in name or scene file
  std::string backend = "auto";     // cpu, optix, auto
  std::vector<std::string> sets;    // scene overrides (--set and the strategy/depth/seed options)
  int width = 0, height = 0;        // window size; 0 = from the scene's resolution
  float scale = 0.f;                // resolution scale; 0 = automatic
  int frames = 0;                   // > 0: render this many frames, then exit
  bool headless = false;            // an EGL context's offscreen framebuffer instead of a window (headless_gl.h)
  std::string screenshot;           // written after --frames frames (or on exit)
  std::string camera_path;          // scripted actions (camera_path.h)
  int spp_per_frame = 1;
  float exposure = 0.f;
  BackendOptions backend_options;   // --threads, --wavefront, --traversal, --tune
  std::string split;                // "LEFT,RIGHT": start in split-screen mode
  bool equal_time = false;
  bool hide_panel = false;
  std::string display = "auto";     // auto, interop, host: how the image reaches the screen (progressive.h)
};

}  // namespace pn::viewer
