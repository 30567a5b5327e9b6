// Fuzz target: OBJ models with their MTL. The input is the OBJ text, optionally
// followed by a NUL byte and the MTL text (the OBJ names it "mtllib m.mtl").
#include <cstdint>
#include <string>

#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (pn::fuzz::escapes(data, size)) return 0;
  size_t obj_size = size, mtl_size = 0;
  for (size_t i = 0; i < size; ++i)
    if (data[i] == 0) {
      obj_size = i;
      mtl_size = size - i - 1;
      break;
    }
  pn::fuzz::scratch_file("m.mtl", data + size - mtl_size, mtl_size);
  const std::string path = pn::fuzz::scratch_file("m.obj", data, obj_size);
  pn::fuzz::load_model_file(path);
  return 0;
}
