// The GPU backend: OptiX 9 over CUDA. The same integrator as the CPU backend
// (core/integrator.h runs in the raygen program), one GAS per mesh (compacted),
// one GAS of spheres, an IAS over every instance, progressive accumulation of
// per-pixel sums and sums of squares in device memory.
//
// This header has no CUDA or OptiX types, so any C++ code may include it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "backends/trace_stage.h"
#include "render/backend.h"

namespace pn {

// The progressive interface of GPU-resident clients (the viewer's interop path,
// the Python module's device images): accumulate on the device across launches
// and read the sums where they are. render() (the Backend interface) is built
// from the same calls and adds the sums into a Film.
class OptixBackend : public Backend {
 public:
  // Zeroes the device accumulation for a frame of the camera's size.
  virtual void reset(const FrameSpec& frame) = 0;
  // Adds samples [first_sample, first_sample + count) of every pixel to the device
  // accumulation, spp_per_launch() samples per launch; `progress` after each launch.
  virtual void accumulate(const FrameSpec& frame, uint32_t first_sample, uint32_t count,
                          const ProgressFn& progress = nullptr) = 0;
  // Samples per pixel accumulated on the device since reset().
  virtual uint64_t accumulated_samples() const = 0;
  // The device accumulation's per-pixel sums since reset(): 3 doubles a pixel
  // (RGB, row 0 at the top, laid out like Film::sum()), a CUDA device pointer;
  // complete when accumulate() returns. The viewer's interop path adds them
  // into its own device images (src/apps/viewer/device_image.h).
  virtual const double* device_sums() const = 0;
  // The per-pixel sums of squares, laid out alike (the Python module's variance).
  virtual const double* device_sums_sq() const = 0;
  // Samples per pixel per launch; 0 = automatic (1 at 1 Mpixel and above, more
  // for small images so that each launch still fills the GPU).
  virtual void set_spp_per_launch(int spp) = 0;
  // "builtin" or "custom": how spheres are intersected (OptiX built-in sphere
  // primitives or a custom intersection program running core/geometry.h).
  virtual std::string sphere_mode() const = 0;
  // The CUDA device this backend renders on (device_sums() are its memory).
  virtual int cuda_device() const = 0;

  // The trace stage's optix implementation: trace-only launches over `count`
  // rays in device memory, queued on cuda_stream(). Closest hits: one HitRecord
  // a ray (instance kTraceMiss for a miss). Shadow rays: blocked bits
  // (trace_bit_words(count) words, zeroed here first).
  virtual void trace_closest(const TraceRay* rays, uint32_t count, HitRecord* hits) = 0;
  virtual void trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits) = 0;
  virtual void* cuda_stream() const = 0;  // a cudaStream_t
  // The scene as the device programs see it (device arrays, texture objects),
  // for other GPU code that resolves hits or tests alpha masks.
  virtual SceneView device_scene_view() const = 0;
  // OPTIX_DEVICE_PROPERTY_RTCORE_VERSION: 0 where the GPU has no RT cores
  // (OptiX then traverses in software).
  virtual unsigned rtcore_version() const = 0;
};

// Builds the backend for `scene` on GPU options.device (0 by default): every
// call sets that CUDA device on the calling thread first, so that backends of
// several GPUs may render concurrently from threads of their own (MultiBackend;
// make_backend builds one per GPU that --gpus selects). Throws std::runtime_error with one
// line (no GPU or driver, OptiX ABI not supported by the driver, out of GPU
// memory with the scene's size, any failed CUDA or OptiX call).
// options.tuning (render/gpu_tuning.h) tunes it: optix_spheres, optix_launch, the wavefront's keys, ...
std::unique_ptr<Backend> make_optix_backend(const Scene& scene);
std::unique_ptr<Backend> make_optix_backend(const Scene& scene, const BackendOptions& options);

// True when a GPU, its driver and OptiX can be used; otherwise false with the
// reason in one line in *why.
bool optix_available(std::string* why);

// The number of CUDA devices this process sees (CUDA_VISIBLE_DEVICES applies);
// 0 when optix_available() is false.
int optix_device_count();

}  // namespace pn
