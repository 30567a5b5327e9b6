// The GPU's kernel feature levels, shared by the OptiX megakernel's raygen programs and the wavefront's shading
// kernels (backends/gpu: what the GPU path tracers share, below optix/, cuda/ and wavefront/).
#pragma once

#include <cstdint>

#include "core/scene_view.h"

namespace pn {
namespace gpu {

// The raygen programs' feature levels (core/scene_view.h, SceneFeature): every
// strategy, with and without MIS, is compiled once per level, and the backend runs the smallest level
// that covers the scene, so that a Lambertian Cornell box does not pay for the
// GGX, texture and environment code in its megakernel.
constexpr uint32_t kNumFeatureLevels = 3;
enum : uint32_t { kFeatureLevel_basic = 0, kFeatureLevel_textured = 1, kFeatureLevel_full = 2 };
// No level holds the code of ltc, sg-bvh and slc (kExtraLightSampling): the configurations that run them have
// programs and kernels of their own, at the full level (the megakernel's _extra raygens, device_programs.cu; the
// wavefront's kernels with kExtra, wavefront_gpu.cu).
constexpr uint32_t kFeatureLevels[kNumFeatureLevels] = {0, kFeatureShading | kFeatureTextures, kSceneFeatures};
constexpr const char* kFeatureLevelNames[kNumFeatureLevels] = {"basic", "textured", "full"};

}  // namespace gpu
}  // namespace pn
