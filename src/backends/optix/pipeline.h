// The OptiX backend's programs: one module compiled from the embedded OptiX-IR
// (by OptiX's tasks, on all the host's cores), the raygen programs of every
// strategy x MIS mode at the scene's feature level, the
// trace-only programs and the guides', the miss and hit groups, the pipeline
// and its shader binding table. Internal to the backend.
#pragma once

#include <cstdint>
#include <vector>

#include <optix.h>

#include "backends/optix/accels.h"
#include "backends/optix/device_memory.h"
#include "backends/optix/launch_params.h"
#include "render/backend.h"

namespace pn {
namespace optix {

class Pipeline {
 public:
  // Compiles and links the programs for a scene of `features` (SceneFeature
  // bits): its raygens are those of the smallest feature level covering them.
  // `max_registers`: the module's register limit (GpuTuning::optix_maxreg; 0:
  // OptiX's default). Adds the compile time to `stats`.
  void build(OptixDeviceContext context, uint32_t features, SphereMode spheres, int max_registers,
             const SceneSize& size, SceneBuildStats& stats);
  void release();
  OptixPipeline get() const { return pipeline_; }
  uint32_t feature_level() const { return feature_level_; }  // index into gpu::kFeatureLevels
  // The shader binding table whose raygen record is program `raygen`
  // (raygen_index(strategy, mis, extra), or kRaygenTraceClosest, ...).
  OptixShaderBindingTable sbt(uint32_t raygen) const;

 private:
  OptixModule create_module(const OptixModuleCompileOptions& mco, const OptixPipelineCompileOptions& pco);
  void build_sbt(const SceneSize& size);

  OptixDeviceContext context_ = nullptr;
  uint32_t feature_level_ = gpu::kNumFeatureLevels - 1;
  OptixModule module_ = nullptr, sphere_is_module_ = nullptr;
  std::vector<OptixProgramGroup> raygen_;  // by raygen_index(strategy, mis, extra), then kRaygenTraceClosest, ...
  OptixProgramGroup miss_[kNumMissPrograms] = {}, hit_[kNumHitGroups] = {};
  OptixPipeline pipeline_ = nullptr;
  OptixShaderBindingTable sbt_ = {};
  DeviceBuffer sbt_raygen_, sbt_miss_, sbt_hit_;
};

}  // namespace optix
}  // namespace pn
