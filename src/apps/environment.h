// The environment variables penumbra reads, every one of them here: code below src/apps never reads the
// environment; the applications (the `penumbra` executable, the Python module) read it once, before any scene is
// loaded, and pass the values down.
//
//   PENUMBRA_SCENES  the folder of the built-in scenes' model data (sponza/, models/), searched first
//                    (scene.h: SceneSearch::scenes; scripts/fetch-scenes.sh fills it)
//   PENUMBRA_DATA    the folder of the data/ files (the glossy scene's sky), searched first (SceneSearch::data; the
//                    Python package sets it to its own copy)
//   XDG_CACHE_HOME, HOME  where `converge` caches ground truths when --cache is not given:
//                    $XDG_CACHE_HOME/penumbra, else $HOME/.cache/penumbra (converge.h: default_cache_dir)
//
// The GPU's tuning knobs are options, not variables (render/gpu_tuning.h: --tune KEY=VALUE). The CUDA driver
// reads its own (CUDA_VISIBLE_DEVICES, ...). Header-only, so that the Python module uses the same.
#pragma once

#include <cstdlib>
#include <string>

#include "apps/converge.h"
#include "scene/scene.h"

namespace pn {

// The variable's value, "" where it is unset.
inline std::string environment_variable(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// The scene search roots from $PENUMBRA_SCENES and $PENUMBRA_DATA (set_scene_search).
inline SceneSearch scene_search_from_environment() {
  SceneSearch s;
  s.scenes = environment_variable("PENUMBRA_SCENES");
  s.data = environment_variable("PENUMBRA_DATA");
  return s;
}

// converge's default cache folder from $XDG_CACHE_HOME and $HOME.
inline std::string cache_dir_from_environment() {
  return default_cache_dir(environment_variable("XDG_CACHE_HOME"), environment_variable("HOME"));
}

}  // namespace pn
