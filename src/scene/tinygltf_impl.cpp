// The one translation unit that compiles tinygltf (Debian's libtinygltf-dev
// ships the header; its implementation is compiled here). The target defines
// TINYGLTF_NO_STB_IMAGE, TINYGLTF_NO_STB_IMAGE_WRITE and TINYGLTF_NO_EXTERNAL_IMAGE
// for every file that includes the header: images are decoded by io/image_load
// (model_io.cpp), never by tinygltf, and JSON is the system's nlohmann json.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
