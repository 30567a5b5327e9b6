// The code a shading function compiles: a mask of features, each bit's code compiled away where it is off.
#pragma once

#include <cstdint>

namespace pn {

// What a scene uses beyond Lambertian, untextured, flat-shaded surfaces lit by
// lights with a surface, and one bit of the configuration. The shading code is
// templated on a mask of these: with a bit off, its code compiles away. The GPU
// backend builds one raygen program per strategy and per feature level and runs
// the smallest that covers the scene, because its megakernel is bound by
// instruction fetch and code size (src/backends/optix/NOTES.md); the CPU backend
// always runs kAllFeatures.
enum SceneFeature : uint32_t {
  kFeatureShading = 1u << 0,      // per-vertex normals or texture coordinates
  kFeatureTextures = 1u << 1,     // texture lookups: material textures, normal maps, emission textures
  kFeatureSpecular = 1u << 2,     // a GGX lobe: a material with metallic > 0 or specular > 0
  kFeatureEnvironment = 1u << 3,  // an environment map
  // Not the scene's but the configuration's: the light sampling other configurations should not pay for, a bit
  // each (extra_light_sampling, core/integrator.h): the ltc strategy, sg-bvh selection, stochastic lightcuts.
  // Without its bit ltc samples as projected-solid-angle, sg-bvh and slc select as bvh: a kernel compiled
  // without it must never run them. The wavefront compiles a shading kernel for each (wavefront_gpu.cu): their
  // functions' calls and stack had cost every other configuration up to 45% a sample, and each other up to 74%.
  kFeatureLtc = 1u << 4,
  kFeatureSgBvh = 1u << 5,
  kFeatureSlc = 1u << 6,
};
constexpr uint32_t kSceneFeatures = kFeatureShading | kFeatureTextures | kFeatureSpecular | kFeatureEnvironment;
constexpr uint32_t kExtraLightSampling = kFeatureLtc | kFeatureSgBvh | kFeatureSlc;
constexpr uint32_t kAllFeatures = kSceneFeatures | kExtraLightSampling;

}  // namespace pn
