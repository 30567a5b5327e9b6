// The OptiX backend's acceleration structures (accels.h).
#include "backends/optix/accels.h"

#include <algorithm>
#include <chrono>
#include <cstring>

#include <optix_stubs.h>

#include "backends/optix/launch_params.h"
#include "core/geometry.h"

namespace pn {
namespace optix {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Any-hit (alpha masks) only where a masked material can be hit: per GAS
// SBT record through the geometry flags, per instance through its flags.
const unsigned kOpaque = OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT;
const unsigned kMasked = OPTIX_GEOMETRY_FLAG_NONE;
const unsigned kMixed[2] = {kOpaque, kMasked};  // SBT records 0 (opaque) and 1 (masked)

}  // namespace

void Accels::build(OptixDeviceContext context, cudaStream_t stream, const Scene& scene, const std::vector<MeshView>& meshes,
                   SphereMode sphere_mode, const SceneSize& size, SceneBuildStats& stats) {
  release();
  context_ = context;
  stream_ = stream;
  size_ = &size;
  // Whether a triangle's material is alpha-masked (per-face SBT records).
  auto masked_material = [&](uint32_t material) {
    return material < scene.materials.size() && scene.materials[material].alpha_mode == AlphaMode::Mask;
  };
  sphere_mode_ = sphere_mode;
  compacted_size_.alloc(sizeof(uint64_t), "acceleration structure sizes", size);

  std::vector<bool> used(scene.meshes.size(), false), mesh_masked(scene.meshes.size(), false);
  bool any_masked = false;
  for (const Instance& inst : scene.instances) {
    used.at(inst.mesh) = true;
    if (scene.instance_alpha_masked(inst)) mesh_masked[inst.mesh] = true, any_masked = true;
  }
  ray_flags_ = any_masked ? OPTIX_RAY_FLAG_NONE : OPTIX_RAY_FLAG_DISABLE_ANYHIT;

  // One GAS per used, non-empty mesh.
  mesh_gas_.resize(scene.meshes.size());
  std::vector<OptixTraversableHandle> mesh_handle(scene.meshes.size(), 0);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const TriangleMesh& mesh = scene.meshes[m];
    if (!used[m] || mesh.indices.empty() || mesh.positions.empty()) continue;
    OptixBuildInput in = {};
    in.type = OPTIX_BUILD_INPUT_TYPE_TRIANGLES;
    CUdeviceptr vertices = reinterpret_cast<CUdeviceptr>(meshes[m].positions);
    in.triangleArray.vertexFormat = OPTIX_VERTEX_FORMAT_FLOAT3;
    in.triangleArray.vertexStrideInBytes = sizeof(Vec3);
    in.triangleArray.numVertices = unsigned(mesh.positions.size());
    in.triangleArray.vertexBuffers = &vertices;
    in.triangleArray.indexFormat = OPTIX_INDICES_FORMAT_UNSIGNED_INT3;
    in.triangleArray.indexStrideInBytes = 3 * sizeof(uint32_t);
    in.triangleArray.numIndexTriplets = unsigned(mesh.indices.size());
    in.triangleArray.indexBuffer = reinterpret_cast<CUdeviceptr>(meshes[m].indices);
    in.triangleArray.flags = mesh_masked[m] ? &kMasked : &kOpaque;
    in.triangleArray.numSbtRecords = 1;
    // Per-face materials mixing opaque and masked ones: the masked triangles
    // get SBT record 1, the only one whose any-hit program runs.
    DeviceBuffer sbt_index;
    if (mesh_masked[m] && !mesh.face_materials.empty()) {
      std::vector<uint8_t> record(mesh.face_materials.size());
      size_t masked = 0;
      for (size_t t = 0; t < record.size(); ++t) {
        record[t] = masked_material(mesh.face_materials[t]) ? 1 : 0;
        masked += record[t];
      }
      if (masked < record.size()) {
        sbt_index.upload(record, "a mesh's per-triangle SBT indices", size);
        in.triangleArray.flags = kMixed;
        in.triangleArray.numSbtRecords = 2;
        in.triangleArray.sbtIndexOffsetBuffer = sbt_index.dptr();
        in.triangleArray.sbtIndexOffsetSizeInBytes = 1;
        in.triangleArray.sbtIndexOffsetStrideInBytes = 1;
      }
    }
    const auto t0 = Clock::now();
    mesh_handle[m] = build_accel(in, kGasBuildFlags, true, &mesh_gas_[m], "a mesh's acceleration structure");
    stats.gas_build_ms += ms_since(t0);
    stats.accel_bytes += mesh_gas_[m].size();
    ++stats.gas_count;
  }

  // The IAS: every placement of a mesh (instanceId = its index in
  // SceneView::instances), plus the spheres' GAS once with the identity.
  mesh_instances_.clear();
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    if (!mesh_handle[inst.mesh]) continue;
    OptixInstance o = {};
    std::memcpy(o.transform, inst.to_world.m, sizeof o.transform);
    o.instanceId = unsigned(i);
    o.sbtOffset = kSbtMesh;
    o.visibilityMask = 255;
    o.flags = scene.instance_alpha_masked(inst) ? OPTIX_INSTANCE_FLAG_NONE : OPTIX_INSTANCE_FLAG_DISABLE_ANYHIT;
    o.traversableHandle = mesh_handle[inst.mesh];
    mesh_instances_.push_back(o);
  }
  rebuild_spheres(scene, stats);
}

// The spheres' GAS (world space) and the IAS over mesh_instances_ and it.
void Accels::rebuild_spheres(const Scene& scene, SceneBuildStats& stats) {
  const SceneSize& size = *size_;
  // The spheres' GAS, world space.
  OptixTraversableHandle sphere_handle = 0;
  sphere_gas_.release();
  if (!scene.spheres.empty()) {
    const size_t n = scene.spheres.size();
    OptixBuildInput in = {};
    DeviceBuffer centers, radii, aabbs;
    CUdeviceptr centers_ptr = 0, radii_ptr = 0, aabbs_ptr = 0;
    if (sphere_mode_ == SphereMode::Builtin) {
      std::vector<Vec3> c(n);
      std::vector<float> r(n);
      for (size_t i = 0; i < n; ++i) c[i] = scene.spheres[i].center, r[i] = scene.spheres[i].radius;
      centers.upload(c, "sphere centres", size);
      radii.upload(r, "sphere radii", size);
      centers_ptr = centers.dptr();
      radii_ptr = radii.dptr();
      in.type = OPTIX_BUILD_INPUT_TYPE_SPHERES;
      in.sphereArray.vertexBuffers = &centers_ptr;
      in.sphereArray.vertexStrideInBytes = sizeof(Vec3);
      in.sphereArray.numVertices = unsigned(n);
      in.sphereArray.radiusBuffers = &radii_ptr;
      in.sphereArray.radiusStrideInBytes = sizeof(float);
      in.sphereArray.singleRadius = 0;
      in.sphereArray.flags = &kOpaque;
      in.sphereArray.numSbtRecords = 1;
    } else {
      std::vector<OptixAabb> boxes(n);
      for (size_t i = 0; i < n; ++i) {
        const Sphere& s = scene.spheres[i];
        const float r = sphere_bounds_radius(s.radius);  // the CPU's bounds too
        boxes[i] = {s.center.x - r, s.center.y - r, s.center.z - r, s.center.x + r, s.center.y + r, s.center.z + r};
      }
      aabbs.upload(boxes, "sphere bounds", size);
      aabbs_ptr = aabbs.dptr();
      in.type = OPTIX_BUILD_INPUT_TYPE_CUSTOM_PRIMITIVES;
      in.customPrimitiveArray.aabbBuffers = &aabbs_ptr;
      in.customPrimitiveArray.numPrimitives = unsigned(n);
      in.customPrimitiveArray.strideInBytes = sizeof(OptixAabb);
      in.customPrimitiveArray.flags = &kOpaque;
      in.customPrimitiveArray.numSbtRecords = 1;
    }
    const auto t0 = Clock::now();
    sphere_handle = build_accel(in, kGasBuildFlags, true, &sphere_gas_, "the spheres' acceleration structure");
    stats.gas_build_ms += ms_since(t0);
    stats.accel_bytes += sphere_gas_.size();
    ++stats.gas_count;
  }

  std::vector<OptixInstance> instances = mesh_instances_;
  const Affine identity;
  if (sphere_handle) {
    OptixInstance o = {};
    std::memcpy(o.transform, identity.m, sizeof o.transform);
    o.instanceId = unsigned(scene.instances.size());
    o.sbtOffset = kSbtSphere;
    o.visibilityMask = 255;
    o.flags = OPTIX_INSTANCE_FLAG_DISABLE_ANYHIT;
    o.traversableHandle = sphere_handle;
    instances.push_back(o);
  }
  ias_.release();
  if (instances.empty()) {
    handle_ = 0;  // nothing to hit: every ray runs the miss program
    return;
  }
  DeviceBuffer ias_instances;
  ias_instances.upload(instances, "the instance list", size);
  OptixBuildInput in = {};
  in.type = OPTIX_BUILD_INPUT_TYPE_INSTANCES;
  in.instanceArray.instances = ias_instances.dptr();
  in.instanceArray.numInstances = unsigned(instances.size());
  const auto t0 = Clock::now();
  handle_ = build_accel(in, OPTIX_BUILD_FLAG_PREFER_FAST_TRACE, false, &ias_, "the instance acceleration structure");
  stats.ias_build_ms = ms_since(t0);
  stats.accel_bytes += ias_.size();
}

// Builds one acceleration structure into `out`; compacts GASes.
OptixTraversableHandle Accels::build_accel(const OptixBuildInput& input, unsigned flags, bool compact, DeviceBuffer* out,
                                           const char* what) {
  OptixAccelBuildOptions o = {};
  o.buildFlags = flags | (compact ? unsigned(OPTIX_BUILD_FLAG_ALLOW_COMPACTION) : 0u);
  o.operation = OPTIX_BUILD_OPERATION_BUILD;
  OptixAccelBufferSizes sizes = {};
  PN_OPTIX(optixAccelComputeMemoryUsage(context_, &o, &input, 1, &sizes));
  DeviceBuffer temp, full;
  temp.alloc(std::max<size_t>(sizes.tempSizeInBytes, 8), what, *size_);
  full.alloc(sizes.outputSizeInBytes, what, *size_);
  OptixAccelEmitDesc emit = {};
  emit.type = OPTIX_PROPERTY_TYPE_COMPACTED_SIZE;
  emit.result = compacted_size_.dptr();
  OptixTraversableHandle handle = 0;
  PN_OPTIX(optixAccelBuild(context_, stream_, &o, &input, 1, temp.dptr(), temp.size(), full.dptr(), full.size(),
                           &handle, compact ? &emit : nullptr, compact ? 1 : 0));
  PN_CUDA(cudaStreamSynchronize(stream_));
  if (!compact) {
    *out = std::move(full);
    return handle;
  }
  uint64_t compacted = 0;
  PN_CUDA(cudaMemcpy(&compacted, compacted_size_.as<void>(), sizeof compacted, cudaMemcpyDeviceToHost));
  if (compacted == 0 || compacted >= full.size()) {
    *out = std::move(full);
    return handle;
  }
  out->alloc(compacted, what, *size_);
  PN_OPTIX(optixAccelCompact(context_, stream_, handle, out->dptr(), out->size(), &handle));
  PN_CUDA(cudaStreamSynchronize(stream_));
  return handle;
}

void Accels::release() {
  mesh_gas_.clear();
  for (DeviceBuffer* b : {&sphere_gas_, &ias_, &compacted_size_}) b->release();
  handle_ = 0;
}

}  // namespace optix
}  // namespace pn
