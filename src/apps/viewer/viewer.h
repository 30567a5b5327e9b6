// `penumbra view`: the interactive viewer (docs/viewer.md).
#pragma once

#include "apps/viewer/viewer_options.h"

namespace pn::viewer {

// Opens the window (or, headless, an offscreen framebuffer) and runs until it
// is closed or the automation ends.
// Returns the exit status; throws std::runtime_error (one line) on failure,
// including "no display" and "no OpenGL 3.3", which point to `penumbra render`.
int run_viewer(const ViewerOptions& options);

}  // namespace pn::viewer
