// What the host hands the OptiX device programs: one struct of launch
// parameters (the `params` constant). The scene is the core's SceneView, its
// arrays in device memory and its textures CUDA texture objects, so the device
// programs resolve hits and shade with exactly the code the CPU backend runs.
// Compiled by both the host C++ compiler and nvcc (-optix-ir).
#pragma once

#include <cstdint>

#include <optix_types.h>
#include <vector_types.h>

#include "core/camera.h"
#include "core/integrator.h"
#include "core/reservoir.h"
#include "backends/trace_stage.h"
#include "core/scene_view.h"
#include "backends/gpu/feature_levels.h"

namespace pn {
namespace optix {

// Payload register 1 (the instance) holds this value when a radiance ray missed.
constexpr uint32_t kMissMarker = 0xFFFFFFFFu;
static_assert(kMissMarker != kSphereInstance, "miss and sphere markers must differ");

// Payload registers of a radiance ray: t, instance, primitive, b1, b2 (a
// HitRecord); a shadow ray uses register 0 alone (occluded).
constexpr unsigned kNumPayloadValues = 5;

// Program groups: hit groups by geometry kind, miss programs by ray kind (the
// missSBTIndex of optixTrace).
enum : uint32_t { kHitGroupMesh = 0, kHitGroupSphere = 1, kNumHitGroups = 2 };
enum : uint32_t { kMissRadiance = 0, kMissShadow = 1, kNumMissPrograms = 2 };

// Hit-group SBT records (one ray type). A mesh GAS has one SBT record (index 0),
// or two when its triangles mix opaque and alpha-masked materials (record 0:
// opaque, any-hit disabled by the geometry flags; record 1: masked); both
// records are the mesh hit group. The spheres' instance starts at kSbtSphere.
enum : uint32_t { kSbtMesh = 0, kSbtSphere = 2, kNumHitRecords = 3 };

// Raygen programs: four per strategy, in registry order: without and with MIS, each at the scene's feature level
// and with the extra light sampling (core/features.h: ltc, sg-bvh, slc; at the full level); then the trace stage's
// and the guides' programs.
constexpr uint32_t kNumRaygens = 4 * uint32_t(kNumStrategies);
PN_FN uint32_t raygen_index(Strategy s, Mis mis, bool extra) {
  return 4u * uint32_t(s) + (mis == Mis::None ? 0u : 1u) + (extra ? 2u : 0u);
}
// The trace stage's trace-only launches (backends/trace_stage.h): rays in, hits or bits out.
constexpr uint32_t kRaygenTraceClosest = kNumRaygens;
constexpr uint32_t kRaygenTraceShadow = kNumRaygens + 1;
// The denoiser's guides (core/aov.h): one thread per pixel, at the scene's feature level.
constexpr uint32_t kRaygenGuides = kNumRaygens + 2;
constexpr uint32_t kNumRaygenPrograms = kNumRaygens + 3;

struct LaunchParams {
  OptixTraversableHandle handle = 0;  // the IAS; 0 for an empty scene (every ray misses)
  SceneView scene;                    // every array in device memory, textures as texture objects
  Camera camera;
  IntegratorSettings integrator;
  uint32_t seed = 0;
  uint32_t first_sample = 0;  // sample index of this launch's first sample of every pixel
  uint32_t spp = 1;           // samples per pixel in this launch
  // OPTIX_RAY_FLAG_DISABLE_ANYHIT when no surface is alpha-masked, else
  // OPTIX_RAY_FLAG_NONE; added to the flags of every ray.
  uint32_t ray_flags = 0;
  // Written for every pixel by each launch (one thread owns a pixel):
  //   sum.xyz    sum of the launch's finite sample values   sum.w    rays traced
  //   sum_sq.xyz sum of their squares                        sum_sq.w non-finite samples
  float4* sum = nullptr;
  float4* sum_sq = nullptr;
  // The guides' launch (kRaygenGuides): each pixel's albedo and normal (xyz,
  // w = 0) over `spp` camera rays.
  float4* guide_albedo = nullptr;
  float4* guide_normal = nullptr;
  // Trace-only launches (1D, trace_count threads): closest hits into trace_hits
  // (instance kTraceMiss for a miss), or blocked bits ORed into trace_bits.
  const TraceRay* trace_rays = nullptr;
  HitRecord* trace_hits = nullptr;
  uint32_t* trace_bits = nullptr;
  uint32_t trace_count = 0;
  // Where set, the number of rays is this device value instead (at most trace_count, the launch's width): the
  // wavefront's queues, whose lengths the GPU writes, in launches a CUDA graph replays.
  const uint32_t* trace_count_device = nullptr;
};

}  // namespace optix
}  // namespace pn
