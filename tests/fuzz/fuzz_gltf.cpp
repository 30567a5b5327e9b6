// Fuzz target: glTF 2.0 models, .gltf (JSON, buffers as data URIs) or .glb
// (binary, when the input starts with "glTF"), with their node hierarchy,
// accessors, materials and embedded images.
#include <cstdint>
#include <cstring>
#include <string>

#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (pn::fuzz::escapes(data, size)) return 0;
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const std::string path = pn::fuzz::scratch_file(glb ? "m.glb" : "m.gltf", data, size);
  pn::fuzz::load_model_file(path);
  return 0;
}
