// The OptiX backend's device memory: buffers and textures that free
// themselves and turn a failed allocation into one line naming what it was for
// and the scene's size; the estimate of a scene's needs checked before building;
// and the scene's arrays in device memory (build_scene_view's device twin of the
// CPU's host view). Internal to the backend.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <cuda.h>
#include <cuda_runtime.h>

#include "backends/optix/context.h"
#include "io/host_memory.h"
#include "scene/scene.h"

namespace pn {
namespace optix {

// What out-of-memory messages say about the scene (nothing when it is empty:
// a buffer not of the scene's, the denoiser's).
struct SceneSize {
  size_t triangles = 0, meshes = 0, instances = 0, spheres = 0;
  bool empty() const { return triangles == 0 && meshes == 0 && instances == 0 && spheres == 0; }
  std::string describe() const {
    auto n = [](size_t v, const char* one, const char* many) { return std::to_string(v) + " " + (v == 1 ? one : many); };
    return n(triangles, "triangle", "triangles") + " (" + n(meshes, "mesh", "meshes") + ", " +
           n(instances, "instance", "instances") + "), " + n(spheres, "sphere", "spheres");
  }
};

[[noreturn]] void throw_out_of_memory(size_t bytes, const std::string& what, const SceneSize& scene);

// Device memory of a scene, estimated on the host from its sizes. The
// acceleration structures use per-primitive bounds that err high (OptiX
// reports the exact sizes only through the device context, per build): a GAS
// keeps about 64 bytes a triangle after compaction, and building the largest
// one needs its temporary and uncompacted buffers (up to 256 bytes a
// triangle) at once; the IAS about 256 bytes an instance with its build.
struct DeviceEstimate {
  uint64_t accels = 0, geometry = 0, textures = 0, frame = 0, fixed = 0;
  int width = 0, height = 0;
  uint64_t total() const { return accels + geometry + textures + frame + fixed; }
  std::string describe() const {
    return "acceleration structures " + format_bytes(accels) + ", geometry and scene arrays " +
           format_bytes(geometry) + ", textures " + format_bytes(textures) + ", a " + std::to_string(width) + "x" +
           std::to_string(height) + " frame " + format_bytes(frame) + ", pipeline " + format_bytes(fixed);
  }
};

DeviceEstimate estimate_device_memory(const Scene& scene);

class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept : ptr_(o.ptr_), size_(o.size_) { o.ptr_ = nullptr, o.size_ = 0; }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      ptr_ = o.ptr_, size_ = o.size_;
      o.ptr_ = nullptr, o.size_ = 0;
    }
    return *this;
  }
  ~DeviceBuffer() { release(); }

  // Allocates `bytes`; an allocation failure becomes the out-of-memory message.
  void alloc(size_t bytes, const char* what, const SceneSize& scene) {
    release();
    if (bytes == 0) return;
    cudaError_t e = cudaMalloc(&ptr_, bytes);
    if (e == cudaErrorMemoryAllocation) {
      ptr_ = nullptr;
      throw_out_of_memory(bytes, what, scene);
    }
    check_cuda(e, "cudaMalloc");
    size_ = bytes;
  }
  // Grows to at least `bytes` (16 or more), keeping an allocation that is large
  // enough already (the denoiser's buffers, sized by the image).
  void ensure(size_t bytes, const char* what, const SceneSize& scene = SceneSize()) {
    if (ptr_ && size_ >= bytes) return;
    alloc(bytes < 16 ? 16 : bytes, what, scene);
  }
  template <class T>
  void upload(const std::vector<T>& v, const char* what, const SceneSize& scene) {
    alloc(v.size() * sizeof(T), what, scene);
    if (!v.empty()) PN_CUDA(cudaMemcpy(ptr_, v.data(), v.size() * sizeof(T), cudaMemcpyHostToDevice));
  }
  void release() {
    if (ptr_) cudaFree(ptr_);  // never throws from a destructor
    ptr_ = nullptr;
    size_ = 0;
  }
  CUdeviceptr dptr() const { return reinterpret_cast<CUdeviceptr>(ptr_); }
  template <class T>
  T* as() const { return static_cast<T*>(ptr_); }
  size_t size() const { return size_; }

 private:
  void* ptr_ = nullptr;
  size_t size_ = 0;
};

// Page-locked host memory (cudaMallocHost), which the GPU copies into at full
// bus speed and asynchronously; pageable memory is staged through a driver
// buffer at a fraction of it. Grows to the largest size asked for.
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  ~PinnedBuffer() { release(); }
  void ensure(size_t bytes) {
    if (ptr_ && size_ >= bytes) return;
    release();
    check_cuda(cudaMallocHost(&ptr_, bytes), "cudaMallocHost");
    size_ = bytes;
  }
  void release() {
    if (ptr_) cudaFreeHost(ptr_);  // never throws from a destructor
    ptr_ = nullptr;
    size_ = 0;
  }
  template <class T>
  T* as() const { return static_cast<T*>(ptr_); }

 private:
  void* ptr_ = nullptr;
  size_t size_ = 0;
};

// One of Scene::textures as a CUDA array and a texture object with the settings
// core/texture.h describes: 8-bit texels read as normalized floats (sRGB decoded
// by the texture unit before filtering for colour textures), float texels as
// they are; bilinear or nearest; repeat wrapping; normalized coordinates.
class DeviceTexture {
 public:
  DeviceTexture() = default;
  DeviceTexture(const DeviceTexture&) = delete;
  DeviceTexture& operator=(const DeviceTexture&) = delete;
  DeviceTexture(DeviceTexture&& o) noexcept : array_(o.array_), object_(o.object_), bytes_(o.bytes_) {
    o.array_ = nullptr, o.object_ = 0, o.bytes_ = 0;
  }
  ~DeviceTexture() { release(); }

  // An empty image (no texels) becomes one white texel, as the CPU's lookup of
  // an empty texture returns white.
  void create(const TextureImage& image, const SceneSize& scene);
  void release() {
    if (object_) cudaDestroyTextureObject(object_);  // never throws from a destructor
    if (array_) cudaFreeArray(array_);
    object_ = 0;
    array_ = nullptr;
    bytes_ = 0;
  }
  cudaTextureObject_t object() const { return object_; }
  size_t bytes() const { return bytes_; }

 private:
  cudaArray_t array_ = nullptr;
  cudaTextureObject_t object_ = 0;
  size_t bytes_ = 0;
};

// The scene's arrays in device memory and the SceneView that points at them,
// built by build_scene_view (scene/scene.h), as the CPU's host view is.
class DeviceScene final : public SceneArrays {
 public:
  explicit DeviceScene(const SceneSize& size) : size_(size) {}
  const void* place(const void* data, size_t bytes, size_t align, const char* what, bool scene_owned) override;
  TextureView texture(const TextureImage& image, size_t index) override;
  void release();
  uint64_t buffer_bytes() const { return buffer_bytes_; }
  uint64_t texture_bytes() const { return texture_bytes_; }

 private:
  const SceneSize& size_;
  std::vector<DeviceBuffer> buffers_;
  std::vector<DeviceTexture> textures_;
  uint64_t buffer_bytes_ = 0, texture_bytes_ = 0;
};

}  // namespace optix
}  // namespace pn
