// Shared by the fuzz targets (tests/fuzz/README.md): a private scratch folder
// for targets whose loaders read files, and the inputs they leave alone.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "scene/model_io.h"

namespace pn::fuzz {

// A folder of this process, made once (in /dev/shm when there is one: faster).
inline const std::string& scratch_dir() {
  static const std::string dir = [] {
    std::string tmpl = (access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp") + std::string("/penumbra-fuzz-XXXXXX");
    if (!mkdtemp(tmpl.data())) std::abort();
    return tmpl;
  }();
  return dir;
}

// Writes bytes to a file of the scratch folder; returns its path.
inline std::string scratch_file(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = scratch_dir() + "/" + name;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Inputs that name files outside the scratch (or data) folder: "..", or
// devices and kernel files, which are endless or huge (/dev/zero as an .mtl
// would be read until memory runs out). penumbra reads what a user names; the
// fuzzer must not wander the machine.
inline bool escapes(const uint8_t* data, size_t size) {
  std::string_view s(reinterpret_cast<const char*>(data), size);
  for (std::string_view bad : {"..", "/dev", "/proc", "/sys", "~"})
    if (s.find(bad) != std::string_view::npos) return true;
  return false;
}

// Loads a model file into an empty scene, as a scene's "models" entry does; a
// SceneError (one line) is a correct answer to a bad file.
inline void load_model_file(const std::string& path) {
  pn::Scene s;
  s.materials.emplace_back();  // material 0, as parse_scene makes it
  try {
    pn::load_model(s, path, "fuzz");
  } catch (const pn::SceneError&) {
  }
}

}  // namespace pn::fuzz
