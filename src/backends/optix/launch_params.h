// What the host hands the OptiX device programs: one struct of launch
// parameters (the `params` constant) plus the per-instance and per-sphere
// records the closest-hit programs read to rebuild a hit with the core helpers.
// Compiled by both the host C++ compiler and nvcc (-optix-ir).
#pragma once

#include <cstdint>

#include <optix_types.h>
#include <vector_types.h>

#include "core/camera.h"
#include "core/integrator.h"
#include "core/transform.h"
#include "core/vec.h"

namespace pn {
namespace optix {

// One placed mesh: the IAS instance whose instanceId is this record's index.
struct DeviceInstance {
  Affine to_world;
  Affine to_object;
  const Vec3* positions = nullptr;  // the mesh's object-space vertices
  const uint32_t* indices = nullptr;  // 3 per triangle
  uint32_t material = 0;
  int32_t light = -1;
};

// One sphere, world space; primitive i of the sphere GAS.
struct DeviceSphere {
  Vec3 center;
  float radius = 1.f;
  uint32_t material = 0;
  int32_t light = -1;
};

// Payload register 7 holds the material, or this value when the ray missed.
constexpr uint32_t kMissMarker = 0xFFFFFFFFu;

// SBT layout: one ray type; hit groups by geometry kind (instance sbtOffset),
// miss programs by ray kind (the missSBTIndex of optixTrace).
enum : uint32_t { kHitGroupMesh = 0, kHitGroupSphere = 1, kNumHitGroups = 2 };
enum : uint32_t { kMissRadiance = 0, kMissShadow = 1, kNumMissPrograms = 2 };

struct LaunchParams {
  OptixTraversableHandle handle = 0;  // the IAS; 0 for an empty scene (every ray misses)
  SceneView scene;                    // lights and materials in device memory
  Camera camera;
  IntegratorSettings integrator;
  uint32_t seed = 0;
  uint32_t first_sample = 0;  // sample index of this launch's first sample of every pixel
  uint32_t spp = 1;           // samples per pixel in this launch
  const DeviceInstance* instances = nullptr;
  const DeviceSphere* spheres = nullptr;
  // Written for every pixel by each launch (one thread owns a pixel):
  //   sum.xyz    sum of the launch's finite sample values   sum.w    rays traced
  //   sum_sq.xyz sum of their squares                        sum_sq.w non-finite samples
  float4* sum = nullptr;
  float4* sum_sq = nullptr;
};

}  // namespace optix
}  // namespace pn
