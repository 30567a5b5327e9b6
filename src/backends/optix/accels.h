// The OptiX backend's acceleration structures: one compacted GAS per placed
// mesh (per-face SBT records where opaque and alpha-masked triangles mix), one
// GAS of the spheres (built-in sphere primitives or custom AABBs), and an IAS
// over every instance plus the spheres' GAS; the last two are built again when
// sphere lights change. Internal to the backend.
#pragma once

#include <vector>

#include <optix.h>

#include "backends/optix/device_memory.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace optix {

enum class SphereMode { Builtin, Custom };

// The GASes' build flags (the pipeline's built-in sphere module must match).
constexpr unsigned kGasBuildFlags = OPTIX_BUILD_FLAG_PREFER_FAST_TRACE;

class Accels {
 public:
  // Builds everything for `scene` from its meshes' device arrays (`meshes`, by
  // Scene::meshes index, as build_scene_view placed them), on `stream`; adds
  // the build times and sizes to `stats`.
  void build(OptixDeviceContext context, cudaStream_t stream, const Scene& scene, const std::vector<MeshView>& meshes,
             SphereMode spheres, const SceneSize& size, SceneBuildStats& stats);
  // The spheres moved or resized (set_sphere_light): their GAS and the IAS built again over the meshes' GASes as
  // they are; handle() changes.
  void rebuild_spheres(const Scene& scene, SceneBuildStats& stats);
  void release();
  // The IAS (0: nothing to hit, every ray misses).
  OptixTraversableHandle handle() const { return handle_; }
  // OPTIX_RAY_FLAG_DISABLE_ANYHIT unless some instance is alpha-masked.
  unsigned ray_flags() const { return ray_flags_; }

 private:
  OptixTraversableHandle build_accel(const OptixBuildInput& input, unsigned flags, bool compact, DeviceBuffer* out,
                                     const char* what);

  OptixDeviceContext context_ = nullptr;
  cudaStream_t stream_ = nullptr;
  const SceneSize* size_ = nullptr;
  SphereMode sphere_mode_ = SphereMode::Custom;
  std::vector<DeviceBuffer> mesh_gas_;
  std::vector<OptixInstance> mesh_instances_;  // the IAS's instances but the spheres
  DeviceBuffer sphere_gas_, ias_, compacted_size_;
  OptixTraversableHandle handle_ = 0;
  unsigned ray_flags_ = OPTIX_RAY_FLAG_DISABLE_ANYHIT;
};

}  // namespace optix
}  // namespace pn
