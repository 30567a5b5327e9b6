// The OptiX backend's programs (pipeline.h).
#include "backends/optix/pipeline.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include <optix_stack_size.h>
#include <optix_stubs.h>

#include "core/integrator.h"

// The device programs, OptiX-IR embedded at build time (embed_file.cmake).
extern const unsigned char penumbra_optix_ir[];
extern const size_t penumbra_optix_ir_size;

namespace pn {
namespace optix {
namespace {

template <class T>
struct alignas(OPTIX_SBT_RECORD_ALIGNMENT) SbtRecord {
  char header[OPTIX_SBT_RECORD_HEADER_SIZE];
  T data;
};
struct Empty {};
using EmptyRecord = SbtRecord<Empty>;

}  // namespace

void Pipeline::build(OptixDeviceContext context, uint32_t features, SphereMode sphere_mode, int max_registers,
                     const SceneSize& size, SceneBuildStats& stats) {
  release();
  context_ = context;
  OptixModuleCompileOptions mco = {};
  mco.maxRegisterCount = max_registers > 0 ? max_registers : OPTIX_COMPILE_DEFAULT_MAX_REGISTER_COUNT;  // tuning
  mco.optLevel = OPTIX_COMPILE_OPTIMIZATION_DEFAULT;
  mco.debugLevel = OPTIX_COMPILE_DEBUG_LEVEL_MINIMAL;

  OptixPipelineCompileOptions pco = {};
  pco.usesMotionBlur = 0;
  pco.traversableGraphFlags = OPTIX_TRAVERSABLE_GRAPH_FLAG_ALLOW_SINGLE_LEVEL_INSTANCING;
  pco.numPayloadValues = kNumPayloadValues;
  pco.numAttributeValues = 2;
  pco.exceptionFlags = OPTIX_EXCEPTION_FLAG_NONE;
  pco.pipelineLaunchParamsVariableName = "params";
  pco.usesPrimitiveTypeFlags = OPTIX_PRIMITIVE_TYPE_FLAGS_TRIANGLE |
                               (sphere_mode == SphereMode::Builtin ? OPTIX_PRIMITIVE_TYPE_FLAGS_SPHERE
                                                                    : OPTIX_PRIMITIVE_TYPE_FLAGS_CUSTOM);

  char log[4096];
  size_t log_size = sizeof log;
  log[0] = 0;
  const auto t_compile = std::chrono::steady_clock::now();
  module_ = create_module(mco, pco);
  if (sphere_mode == SphereMode::Builtin) {
    OptixBuiltinISOptions bo = {};
    bo.builtinISModuleType = OPTIX_PRIMITIVE_TYPE_SPHERE;
    bo.usesMotionBlur = 0;
    bo.buildFlags = kGasBuildFlags;
    PN_OPTIX(optixBuiltinISModuleGet(context_, &mco, &pco, &bo, &sphere_is_module_));
  }

  OptixProgramGroupOptions pgo = {};
  auto make_group = [&](const OptixProgramGroupDesc& d, OptixProgramGroup* g) {
    log_size = sizeof log;
    log[0] = 0;
    PN_OPTIX_LOG(optixProgramGroupCreate(context_, &d, 1, &pgo, log, &log_size, g), log);
  };
  // The raygen programs of every strategy, without and with MIS, named after
  // the registry's enum, at the smallest feature level that covers the scene.
  feature_level_ = gpu::kNumFeatureLevels - 1;
  for (uint32_t l = 0; l < gpu::kNumFeatureLevels; ++l)
    if ((features & ~gpu::kFeatureLevels[l]) == 0) {
      feature_level_ = l;
      break;
    }
  OptixProgramGroupDesc d = {};
  static const char* const strategy_enum_names[] = {
#define PN_X(e, name, impl, nee, desc) #e,
      PN_STRATEGIES(PN_X)
#undef PN_X
  };
  raygen_.assign(kNumRaygenPrograms, nullptr);
  for (int i = 0; i < kNumStrategies; ++i)
    for (Mis mis : {Mis::None, Mis::Power})
      for (bool extra : {false, true}) {
        const std::string entry = std::string("__raygen__") + strategy_enum_names[i] +
                                  (mis == Mis::None ? "_" : "_mis_") +
                                  (extra ? "extra" : gpu::kFeatureLevelNames[feature_level_]);
        d = {};
        d.kind = OPTIX_PROGRAM_GROUP_KIND_RAYGEN;
        d.raygen.module = module_;
        d.raygen.entryFunctionName = entry.c_str();
        make_group(d, &raygen_[raygen_index(Strategy(i), mis, extra)]);
      }
  const std::string guides = std::string("__raygen__guides_") + gpu::kFeatureLevelNames[feature_level_];
  for (auto [index, entry] : {std::pair<uint32_t, const char*>{kRaygenTraceClosest, "__raygen__trace_closest"},
                              {kRaygenTraceShadow, "__raygen__trace_shadow"},
                              {kRaygenGuides, guides.c_str()}}) {
    d = {};
    d.kind = OPTIX_PROGRAM_GROUP_KIND_RAYGEN;
    d.raygen.module = module_;
    d.raygen.entryFunctionName = entry;
    make_group(d, &raygen_[index]);
  }

  d = {};
  d.kind = OPTIX_PROGRAM_GROUP_KIND_MISS;
  d.miss.module = module_;
  d.miss.entryFunctionName = "__miss__radiance";
  make_group(d, &miss_[kMissRadiance]);
  d.miss.entryFunctionName = "__miss__shadow";
  make_group(d, &miss_[kMissShadow]);

  d = {};
  d.kind = OPTIX_PROGRAM_GROUP_KIND_HITGROUP;
  d.hitgroup.moduleCH = module_;
  d.hitgroup.entryFunctionNameCH = "__closesthit__mesh";
  d.hitgroup.moduleAH = module_;  // alpha masks; disabled by the flags of opaque geometry
  d.hitgroup.entryFunctionNameAH = "__anyhit__mesh";
  make_group(d, &hit_[kHitGroupMesh]);

  d = {};
  d.kind = OPTIX_PROGRAM_GROUP_KIND_HITGROUP;
  d.hitgroup.moduleCH = module_;
  d.hitgroup.entryFunctionNameCH = "__closesthit__sphere";
  if (sphere_mode == SphereMode::Builtin) {
    d.hitgroup.moduleIS = sphere_is_module_;
    d.hitgroup.entryFunctionNameIS = nullptr;
  } else {
    d.hitgroup.moduleIS = module_;
    d.hitgroup.entryFunctionNameIS = "__intersection__sphere";
  }
  make_group(d, &hit_[kHitGroupSphere]);

  std::vector<OptixProgramGroup> groups = raygen_;
  for (OptixProgramGroup g : {miss_[0], miss_[1], hit_[0], hit_[1]}) groups.push_back(g);
  OptixPipelineLinkOptions plo = {};
  plo.maxTraceDepth = 1;
  log_size = sizeof log;
  log[0] = 0;
  PN_OPTIX_LOG(optixPipelineCreate(context_, &pco, &plo, groups.data(), unsigned(groups.size()), log, &log_size,
                                   &pipeline_),
               log);

  OptixStackSizes ss = {};
  for (OptixProgramGroup g : groups) PN_OPTIX(optixUtilAccumulateStackSizes(g, &ss, pipeline_));
  unsigned dc_traversal = 0, dc_state = 0, continuation = 0;
  PN_OPTIX(optixUtilComputeStackSizes(&ss, 1, 0, 0, &dc_traversal, &dc_state, &continuation));
  // Graph depth 2: IAS -> GAS.
  PN_OPTIX(optixPipelineSetStackSize(pipeline_, dc_traversal, dc_state, continuation, 2));
  build_sbt(size);
  stats.pipeline_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_compile).count();
}

// The module of every program, compiled by OptiX's tasks on all the host's
// cores: on a cold cache (a new build or driver) the one-threaded
// optixModuleCreate took 44 s on the H200's host before the first render.
// With a warm cache the first task finds the module and makes no others.
OptixModule Pipeline::create_module(const OptixModuleCompileOptions& mco, const OptixPipelineCompileOptions& pco) {
  char log[4096];
  size_t log_size = sizeof log;
  log[0] = 0;
  OptixModule module = nullptr;
  OptixTask first = nullptr;
  PN_OPTIX_LOG(optixModuleCreateWithTasks(context_, &mco, &pco, reinterpret_cast<const char*>(penumbra_optix_ir),
                                          penumbra_optix_ir_size, log, &log_size, &module, &first),
               log);
  std::mutex m;
  std::condition_variable cv;
  std::vector<OptixTask> queue{first};
  unsigned running = 0;
  OptixResult failed = OPTIX_SUCCESS;
  auto worker = [&]() {
    std::unique_lock<std::mutex> lock(m);
    for (;;) {
      cv.wait(lock, [&]() { return !queue.empty() || running == 0; });
      if (queue.empty()) return;  // nothing queued and nothing running: done
      OptixTask task = queue.back();
      queue.pop_back();
      ++running;
      lock.unlock();
      std::array<OptixTask, 64> more;
      unsigned made = 0;
      const OptixResult r = optixTaskExecute(task, more.data(), unsigned(more.size()), &made);
      lock.lock();
      --running;
      if (r != OPTIX_SUCCESS && failed == OPTIX_SUCCESS) failed = r;
      queue.insert(queue.end(), more.begin(), more.begin() + made);
      cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  const unsigned n = std::max(1u, std::min(32u, std::thread::hardware_concurrency()));
  for (unsigned i = 1; i < n; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  PN_OPTIX(failed);
  OptixModuleCompileState state = OPTIX_MODULE_COMPILE_STATE_FAILED;
  PN_OPTIX(optixModuleGetCompilationState(module, &state));
  if (state != OPTIX_MODULE_COMPILE_STATE_COMPLETED) {
    optixModuleDestroy(module);
    throw std::runtime_error("OptiX could not compile the device programs (module state " +
                             std::to_string(int(state)) + ")");
  }
  return module;
}

void Pipeline::build_sbt(const SceneSize& size) {
  std::vector<EmptyRecord> rg(raygen_.size());
  for (size_t i = 0; i < raygen_.size(); ++i) PN_OPTIX(optixSbtRecordPackHeader(raygen_[i], &rg[i]));
  std::vector<EmptyRecord> miss(kNumMissPrograms), hit(kNumHitRecords);
  for (uint32_t i = 0; i < kNumMissPrograms; ++i) PN_OPTIX(optixSbtRecordPackHeader(miss_[i], &miss[i]));
  // Records kSbtMesh and kSbtMesh + 1 (a mixed mesh's masked triangles): the
  // mesh hit group; kSbtSphere: the spheres'.
  for (uint32_t i = 0; i < kNumHitRecords; ++i)
    PN_OPTIX(optixSbtRecordPackHeader(hit_[i < kSbtSphere ? kHitGroupMesh : kHitGroupSphere],
                                      &hit[i]));
  sbt_raygen_.upload(rg, "the shader binding table", size);
  sbt_miss_.upload(miss, "the shader binding table", size);
  sbt_hit_.upload(hit, "the shader binding table", size);
  sbt_ = {};
  sbt_.raygenRecord = sbt_raygen_.dptr();
  sbt_.missRecordBase = sbt_miss_.dptr();
  sbt_.missRecordStrideInBytes = sizeof(EmptyRecord);
  sbt_.missRecordCount = kNumMissPrograms;
  sbt_.hitgroupRecordBase = sbt_hit_.dptr();
  sbt_.hitgroupRecordStrideInBytes = sizeof(EmptyRecord);
  sbt_.hitgroupRecordCount = kNumHitRecords;
}

OptixShaderBindingTable Pipeline::sbt(uint32_t raygen) const {
  OptixShaderBindingTable s = sbt_;
  s.raygenRecord = sbt_raygen_.dptr() + CUdeviceptr(raygen) * sizeof(EmptyRecord);
  return s;
}

void Pipeline::release() {
  if (pipeline_) optixPipelineDestroy(pipeline_);
  for (OptixProgramGroup g : raygen_)
    if (g) optixProgramGroupDestroy(g);
  raygen_.clear();
  for (OptixProgramGroup g : {miss_[0], miss_[1], hit_[0], hit_[1]})
    if (g) optixProgramGroupDestroy(g);
  if (module_) optixModuleDestroy(module_);
  // The built-in IS module belongs to the context.
  pipeline_ = nullptr;
  miss_[0] = miss_[1] = hit_[0] = hit_[1] = nullptr;
  module_ = sphere_is_module_ = nullptr;
  for (DeviceBuffer* b : {&sbt_raygen_, &sbt_miss_, &sbt_hit_}) b->release();
}

}  // namespace optix
}  // namespace pn
