// The OptiX backend's device memory (device_memory.h).
#include "backends/optix/device_memory.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "core/restir.h"
#include "core/texture.h"
#include "io/host_memory.h"

namespace pn {
namespace optix {

// The out-of-memory message of a failed allocation (shared by buffers and textures).
[[noreturn]] void throw_out_of_memory(size_t bytes, const std::string& what, const SceneSize& scene) {
  cudaGetLastError();  // clear it
  size_t free_b = 0, total_b = 0;
  cudaMemGetInfo(&free_b, &total_b);
  throw std::runtime_error("out of GPU memory: " + std::to_string(bytes) + " bytes (" + format_bytes(uint64_t(bytes)) +
                           ") requested for " + what + ", " + format_bytes(uint64_t(free_b)) + " of " +
                           format_bytes(uint64_t(total_b)) + " free" +
                           (scene.empty() ? std::string() : "; scene: " + scene.describe()));
}

DeviceEstimate estimate_device_memory(const Scene& scene) {
  DeviceEstimate e;
  std::vector<bool> used(scene.meshes.size(), false);
  for (const Instance& inst : scene.instances)
    if (inst.mesh < used.size()) used[inst.mesh] = true;
  uint64_t largest = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!used[m]) continue;
    const TriangleMesh& mesh = scene.meshes[m];
    const uint64_t tris = mesh.indices.size(), verts = mesh.positions.size();
    const uint64_t per_vertex =
        sizeof(Vec3) + (mesh.normals.empty() ? 0 : sizeof(Vec3)) + (mesh.uvs.empty() ? 0 : sizeof(Vec2));
    // indices, face materials and face lights, one SBT index byte
    e.geometry += verts * per_vertex + tris * (3 * sizeof(uint32_t) + 2 * sizeof(uint32_t) + 1);
    e.accels += 64 * tris;
    largest = std::max(largest, tris);
  }
  const uint64_t n_inst = scene.instances.size(), n_sph = scene.spheres.size();
  e.accels += 256 * largest + 256 * (n_inst + 1) + 128 * n_sph;
  e.geometry += n_inst * (sizeof(InstanceView) + 80) + n_sph * sizeof(SphereView) +
                scene.lights.size() * (sizeof(Light) + sizeof(float)) + scene.materials.size() * sizeof(Material);
  const Environment& env = scene.environment;
  for (const EnvironmentDistribution* d : {&env.distribution, &env.compensated})
    e.geometry += (d->conditional_func.size() + d->conditional_cdf.size() + d->marginal_func.size() +
                   d->marginal_cdf.size()) * sizeof(float);
  e.geometry += scene.light_bvh.bytes();  // the light BVH's nodes and trails
  for (const TextureImage& t : scene.textures)  // sRGB colour travels decoded, as float (DeviceTexture::create)
    e.textures += t.texels.size() * (t.format == TexelFormat::Rgba8Srgb ? 4 : 1) + sizeof(TextureView);
  // Per pixel: the launch's float4 sums (2 x 16), the double sums (2 x 24), the
  // non-finite counts (4).
  e.width = scene.render.width;
  e.height = scene.render.height;
  e.frame = uint64_t(e.width) * uint64_t(e.height) * 84;
  // restir's frame passes: a shading point and two reservoirs a pixel.
  if (restir_frame_passes(scene.integrator()))
    e.frame += uint64_t(e.width) * uint64_t(e.height) *
               (sizeof(RestirPixel) + 2 * sizeof(Reservoir) +
                (scene.integrator().restir.temporal ? sizeof(RestirPixel) + sizeof(Reservoir) : 0));  // history
  e.fixed = uint64_t(64) << 20;  // module, program groups, SBT, stacks, launch parameters
  return e;
}

void DeviceTexture::create(const TextureImage& image, const SceneSize& scene) {
  release();
  // sRGB colour is decoded here, texel by texel, with the core's srgb_to_linear (the CPU's texel_fetch), and
  // filtered as float: the texture unit's own sRGB decode is not that function (Sponza's direct light, same
  // paths, was 0.014% brighter on the H200 than on the CPU, every lit pixel alike). 4x the memory of 8 bits.
  const bool decode = image.format == TexelFormat::Rgba8Srgb;
  const bool is_float = image.format == TexelFormat::Rgba32f || decode;
  const size_t texel = is_float ? 4 * sizeof(float) : 4;
  int w = image.width, h = image.height;
  const void* texels = image.texels.data();
  std::vector<float> decoded;
  if (decode && w > 0 && h > 0 && image.texels.size() >= size_t(w) * size_t(h) * 4) {
    decoded.resize(size_t(w) * size_t(h) * 4);
    constexpr float k = 1.f / 255.f;
    for (size_t i = 0; i < decoded.size(); ++i)
      decoded[i] = i % 4 == 3 ? image.texels[i] * k : srgb8_to_linear(image.texels[i]);
    texels = decoded.data();
  }
  static const uint8_t white8[4] = {255, 255, 255, 255};
  static const float white32[4] = {1.f, 1.f, 1.f, 1.f};
  if (w <= 0 || h <= 0 || (decoded.empty() && image.texels.size() < size_t(w) * size_t(h) * texel)) {
    w = h = 1;
    texels = is_float ? static_cast<const void*>(white32) : static_cast<const void*>(white8);
  }
  const cudaChannelFormatDesc desc = is_float ? cudaCreateChannelDesc<float4>() : cudaCreateChannelDesc<uchar4>();
  const size_t bytes = size_t(w) * size_t(h) * texel;
  cudaError_t e = cudaMallocArray(&array_, &desc, size_t(w), size_t(h));
  if (e == cudaErrorMemoryAllocation) throw_out_of_memory(bytes, "the texture " + image.path, scene);
  if (e != cudaSuccess) {
    array_ = nullptr;
    throw std::runtime_error(image.path + ": cannot create a " + std::to_string(w) + "x" + std::to_string(h) +
                             " GPU texture (cudaMallocArray: " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e) +
                             ")");
  }
  bytes_ = bytes;
  PN_CUDA(cudaMemcpy2DToArray(array_, 0, 0, texels, size_t(w) * texel, size_t(w) * texel, size_t(h),
                              cudaMemcpyHostToDevice));
  cudaResourceDesc res = {};
  res.resType = cudaResourceTypeArray;
  res.res.array.array = array_;
  cudaTextureDesc td = {};
  td.addressMode[0] = td.addressMode[1] = td.addressMode[2] = cudaAddressModeWrap;
  td.filterMode = image.nearest ? cudaFilterModePoint : cudaFilterModeLinear;
  td.readMode = is_float ? cudaReadModeElementType : cudaReadModeNormalizedFloat;
  td.sRGB = 0;  // decoded above
  td.normalizedCoords = 1;
  PN_CUDA(cudaCreateTextureObject(&object_, &res, &td, nullptr));
}

const void* DeviceScene::place(const void* data, size_t bytes, size_t, const char* what, bool) {
  if (bytes == 0) return nullptr;  // cudaMalloc's alignment (256 bytes) covers every type
  buffers_.emplace_back();
  DeviceBuffer& b = buffers_.back();
  b.alloc(bytes, what, size_);
  PN_CUDA(cudaMemcpy(b.as<void>(), data, bytes, cudaMemcpyHostToDevice));
  buffer_bytes_ += bytes;
  return b.as<void>();
}

TextureView DeviceScene::texture(const TextureImage& image, size_t) {
  textures_.emplace_back();
  textures_.back().create(image, size_);
  texture_bytes_ += textures_.back().bytes();
  TextureView v;
  v.handle = uint64_t(textures_.back().object());
  v.texels = nullptr;
  v.width = image.width;
  v.height = image.height;
  v.format = image.format;
  v.nearest = image.nearest;
  return v;
}

void DeviceScene::release() {
  buffers_.clear();
  textures_.clear();  // destroys the texture objects and their arrays
  buffer_bytes_ = texture_bytes_ = 0;
}

}  // namespace optix
}  // namespace pn
