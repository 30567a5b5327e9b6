// OptiX device programs of the GPU backend, compiled to OptiX-IR at build time
// and embedded in the executable.
//
// The raygen program runs THE integrator, pn::render_sample from
// core/integrator.h (the depth-first driver of its step functions; WAVEFRONT.md
// proposes kernels over the same steps), with a Tracer whose two queries are
// optixTrace calls:
//   intersect(): closest hit. The closest-hit programs only report what the
//                CPU backend's Embree query reports (a HitRecord: t, instance,
//                primitive, barycentrics) in payload registers; the integrator
//                turns it into a shading point with core/scene_view.h.
//   occluded():  any hit. Terminate on the first hit, no closest-hit; the
//                shadow miss program marks the ray visible.
// Both skip alpha-masked holes: the mesh hit group's any-hit program asks the
// core's alpha_discards(), as the CPU's Embree filter functions do. Geometry
// without a masked material has any-hit disabled (geometry and instance flags;
// the ray flags too when the scene has no masked material at all).
// No shading happens outside render_sample and the denoiser's guides
// (render_guides_pixel), both core functions. restir's frame passes (spatial
// and temporal reuse) run in the wavefront (backends/wavefront), not here.
#include <optix.h>

#include "backends/optix/launch_params.h"
#include "backends/gpu/launch_sums.h"
#include "core/aov.h"
#include "core/geometry.h"
#include "core/integrator.h"
#include "core/scene_view.h"

namespace pn {
namespace optix {

// The launch parameters, named `params` for OptiX. LaunchParams holds core types
// whose constructors are user-provided, which a __constant__ variable cannot
// have, so the constant is raw storage of the same size and alignment.
extern "C" {
__constant__ __align__(16) unsigned char params[sizeof(LaunchParams)];
}

namespace {

__forceinline__ __device__ const LaunchParams& P() { return *reinterpret_cast<const LaunchParams*>(params); }

__forceinline__ __device__ float3 to_float3(Vec3 v) { return make_float3(v.x, v.y, v.z); }
__forceinline__ __device__ Vec3 to_vec3(float3 v) { return Vec3(v.x, v.y, v.z); }

// The integrator's view of OptiX. `rays` counts the optixTrace calls of one
// pixel's samples (for rays/s); the raygen program reports it.
struct Tracer {
  mutable uint32_t rays = 0;

  __device__ bool intersect(const Ray& ray, float tmax, HitRecord* hit) const {
    ++rays;
    uint32_t t = 0, instance = kMissMarker, prim = 0, b1 = 0, b2 = 0;
    optixTrace(P().handle, to_float3(ray.o), to_float3(ray.d), 0.f, tmax, 0.f, OptixVisibilityMask(255),
               P().ray_flags, 0, 1, kMissRadiance, t, instance, prim, b1, b2);
    if (instance == kMissMarker) return false;
    hit->t = __uint_as_float(t);
    hit->instance = instance;
    hit->prim = prim;
    hit->b1 = __uint_as_float(b1);
    hit->b2 = __uint_as_float(b2);
    return true;
  }

  __device__ bool occluded(const Ray& ray, float tmax) const {
    ++rays;
    uint32_t occluded = 1u;  // the shadow miss program clears it
    optixTrace(P().handle, to_float3(ray.o), to_float3(ray.d), 0.f, tmax, 0.f, OptixVisibilityMask(255),
               P().ray_flags | OPTIX_RAY_FLAG_TERMINATE_ON_FIRST_HIT | OPTIX_RAY_FLAG_DISABLE_CLOSESTHIT, 0, 1,
               kMissShadow, occluded);
    return occluded != 0u;
  }
};

__forceinline__ __device__ void set_hit_payload(float t, uint32_t instance, uint32_t prim, float b1, float b2) {
  optixSetPayload_0(__float_as_uint(t));
  optixSetPayload_1(instance);
  optixSetPayload_2(prim);
  optixSetPayload_3(__float_as_uint(b1));
  optixSetPayload_4(__float_as_uint(b2));
}

// Thread t of the launch's T threads takes pixels t, t + T, t + 2T, ...: one
// pixel each by default (a W x H or a 1D launch; GpuTuning::optix_launch and
// ::optix_pixels_per_thread tune this), params.spp samples of each,
// summed with their squares.
//
// One raygen program per strategy (the PN_STRATEGIES registry) and MIS on or
// off: with both compile-time constants, the other strategies' sampling code and
// (without MIS) the pdf evaluations fold away, which keeps the megakernel small;
// instruction fetch, not arithmetic, is what stalls warps most in this kernel
// (ncu: stall_no_inst). For the same reason each exists at three feature levels
// (gpu::kFeatureLevels, backends/gpu/feature_levels.h). Balance or power is a run-time choice.
template <Strategy kStrategy, bool kMis, uint32_t kFeatures>
__forceinline__ __device__ void render_pixels() {
  const LaunchParams& p = P();
  IntegratorSettings settings = p.integrator;
  settings.strategy = kStrategy;
  if (!kMis) settings.mis = Mis::None;
  else if (settings.mis == Mis::None) settings.mis = Mis::Power;  // not launched so: the host picks by mis
  const uint3 dim = optixGetLaunchDimensions(), idx = optixGetLaunchIndex();
  const uint32_t threads = dim.x * dim.y;
  const uint32_t width = uint32_t(p.camera.width);
  const uint32_t pixels = width * uint32_t(p.camera.height);
  for (uint32_t pixel = idx.y * dim.x + idx.x; pixel < pixels; pixel += threads) {
    const int px = int(pixel % width), py = int(pixel / width);
    Tracer tracer;
    SampleSums<float> sums;
    for (uint32_t i = 0; i < p.spp; ++i)
      sums.add(render_sample<kFeatures>(tracer, p.scene, p.camera, settings, px, py, p.first_sample + i, p.seed));
    store_launch_sums(p.sum, p.sum_sq, pixel, sums, float(tracer.rays));
  }
}

}  // namespace
}  // namespace optix
}  // namespace pn

using namespace pn;
using namespace pn::optix;

// __raygen__Area_basic, __raygen__Area_mis_basic, __raygen__Area_textured, ..., __raygen__SolidAngle_basic, ...;
// and __raygen__Area_extra, __raygen__Area_mis_extra, ...: every feature and the extra light sampling (ltc,
// sg-bvh, slc: core/features.h), the programs of the configurations that run them. The levels' programs leave
// that code out: its calls and stack had cost every configuration 7-9% a sample with MIS power (H200, 1080p).
#define PN_RAYGEN(e, mis, suffix, level)                                                      \
  extern "C" __global__ void __raygen__##e##suffix##_##level() {                            \
    render_pixels<Strategy::e, mis, gpu::kFeatureLevels[gpu::kFeatureLevel_##level]>();               \
  }
#define PN_RAYGEN_EXTRA(e, mis, suffix)                             \
  extern "C" __global__ void __raygen__##e##suffix##_extra() {    \
    render_pixels<Strategy::e, mis, kAllFeatures>();                \
  }
#define PN_X(e, name, impl, nee, desc)  \
  PN_RAYGEN(e, false, , basic)          \
  PN_RAYGEN(e, true, _mis, basic)       \
  PN_RAYGEN(e, false, , textured)       \
  PN_RAYGEN(e, true, _mis, textured)    \
  PN_RAYGEN(e, false, , full)           \
  PN_RAYGEN(e, true, _mis, full)        \
  PN_RAYGEN_EXTRA(e, false, )           \
  PN_RAYGEN_EXTRA(e, true, _mis)
PN_STRATEGIES(PN_X)
#undef PN_X
#undef PN_RAYGEN_EXTRA
#undef PN_RAYGEN

// One thread per pixel of a W x H launch: the launch index as a pixel; false
// outside the image.
__forceinline__ __device__ bool launch_pixel(int* x, int* y, uint32_t* pixel) {
  const uint3 idx = optixGetLaunchIndex();
  *x = int(idx.x);
  *y = int(idx.y);
  *pixel = idx.y * uint32_t(P().camera.width) + idx.x;
  return *x < P().camera.width && *y < P().camera.height;
}

// The denoiser's guides (core/aov.h), one thread per pixel of a W x H launch;
// at each feature level, as the strategies' programs (the backend runs the
// scene's level: a Cornell box's guides have no GGX or texture code).
template <uint32_t kFeatures>
__forceinline__ __device__ void guides_pixel() {
  const LaunchParams& p = P();
  int x, y;
  uint32_t pixel;
  if (!launch_pixel(&x, &y, &pixel)) return;
  Tracer tracer;
  const GuideSample g = render_guides_pixel<kFeatures>(tracer, p.scene, p.camera, x, y, p.spp, p.seed);
  p.guide_albedo[pixel] = make_float4(g.albedo.x, g.albedo.y, g.albedo.z, 0.f);
  p.guide_normal[pixel] = make_float4(g.normal.x, g.normal.y, g.normal.z, 0.f);
}

extern "C" __global__ void __raygen__guides_basic() { guides_pixel<gpu::kFeatureLevels[gpu::kFeatureLevel_basic]>(); }
extern "C" __global__ void __raygen__guides_textured() { guides_pixel<gpu::kFeatureLevels[gpu::kFeatureLevel_textured]>(); }
extern "C" __global__ void __raygen__guides_full() { guides_pixel<gpu::kFeatureLevels[gpu::kFeatureLevel_full]>(); }

// The trace stage's optix implementation: one ray of params.trace_rays per
// thread, the Tracer's own queries, nothing shaded (bench --probe compares it
// with the cuda traversal on the same rays).
extern "C" __global__ void __raygen__trace_closest() {
  const LaunchParams& p = P();
  const uint32_t i = optixGetLaunchIndex().x;
  if (i >= (p.trace_count_device ? *p.trace_count_device : p.trace_count)) return;
  const TraceRay r = p.trace_rays[i];
  HitRecord h;
  if (!Tracer().intersect(Ray(r.o, r.d), r.tmax, &h)) h.instance = kTraceMiss;
  p.trace_hits[i] = h;
}

extern "C" __global__ void __raygen__trace_shadow() {
  const LaunchParams& p = P();
  const uint32_t i = optixGetLaunchIndex().x;
  if (i >= (p.trace_count_device ? *p.trace_count_device : p.trace_count)) return;
  const TraceRay r = p.trace_rays[i];
  if (Tracer().occluded(Ray(r.o, r.d), r.tmax)) atomicOr(&p.trace_bits[i / 32u], 1u << (i % 32u));
}

extern "C" __global__ void __miss__radiance() { optixSetPayload_1(kMissMarker); }

extern "C" __global__ void __miss__shadow() { optixSetPayload_0(0u); }

// A triangle of a placed mesh: the IAS instance's instanceId is its index in
// SceneView::instances; the integrator rebuilds the hit (resolve_hit).
extern "C" __global__ void __closesthit__mesh() {
  const float2 b = optixGetTriangleBarycentrics();
  set_hit_payload(optixGetRayTmax(), optixGetInstanceId(), optixGetPrimitiveIndex(), b.x, b.y);
}

// Alpha masks: a candidate triangle hit where the material's alpha is below its
// cutoff is a hole, for radiance and shadow rays alike.
extern "C" __global__ void __anyhit__mesh() {
  const SceneView& scene = P().scene;
  const float2 b = optixGetTriangleBarycentrics();
  if (alpha_discards(scene, scene.instances[optixGetInstanceId()], optixGetPrimitiveIndex(), b.x, b.y))
    optixIgnoreIntersection();
}

// A sphere (built-in primitive or custom): primitive i of the spheres' GAS is
// SceneView::spheres[i]; its instance has the identity transform, so t is the
// world ray's, as resolve_hit expects.
extern "C" __global__ void __closesthit__sphere() {
  set_hit_payload(optixGetRayTmax(), kSphereInstance, optixGetPrimitiveIndex(), 0.f, 0.f);
}

// Custom-primitive spheres: the core's ray-sphere test, as Embree's user geometry.
extern "C" __global__ void __intersection__sphere() {
  const SphereView& s = P().scene.spheres[optixGetPrimitiveIndex()];
  const Ray ray(to_vec3(optixGetObjectRayOrigin()), to_vec3(optixGetObjectRayDirection()));
  float t;
  if (intersect_sphere(ray, s.center, s.radius, optixGetRayTmin(), optixGetRayTmax(), &t))
    optixReportIntersection(t, 0u);
}
