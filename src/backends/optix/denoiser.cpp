// The OptiX AI denoiser (see denoiser.h): context, model, device images,
// intensity and average colour, inference.
#include "backends/optix/denoiser.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include <cuda_runtime.h>
#include <optix.h>
#include <optix_stubs.h>

#include "backends/optix/context.h"
#include "backends/optix/device_memory.h"
#include "backends/optix/optix_backend.h"

namespace pn {
namespace {

OptixImage2D float4_image(const optix::DeviceBuffer& m, int width, int height) {
  OptixImage2D img = {};
  img.data = m.dptr();
  img.width = unsigned(width);
  img.height = unsigned(height);
  img.pixelStrideInBytes = unsigned(sizeof(float4));
  img.rowStrideInBytes = unsigned(sizeof(float4)) * unsigned(width);
  img.format = OPTIX_PIXEL_FORMAT_FLOAT4;
  return img;
}

}  // namespace

struct Denoiser::Impl {
  int device = 0;
  OptixDeviceContext context = nullptr;
  OptixDenoiser denoiser = nullptr;
  cudaStream_t stream = nullptr;
  cudaEvent_t start = nullptr, end = nullptr;
  int width = 0, height = 0;  // of the current setup
  OptixDenoiserSizes sizes = {};
  size_t scratch_bytes = 0;
  optix::DeviceBuffer state, scratch, input, albedo, normal, output, intensity, average;
  std::vector<float4> staging;
  float ms = 0.f;

  ~Impl() {
    cudaSetDevice(device);
    if (stream) cudaStreamSynchronize(stream);
    for (optix::DeviceBuffer* m : {&state, &scratch, &input, &albedo, &normal, &output, &intensity, &average})
      m->release();
    if (denoiser) optixDenoiserDestroy(denoiser);
    if (context) optixDeviceContextDestroy(context);
    if (start) cudaEventDestroy(start);
    if (end) cudaEventDestroy(end);
    if (stream) cudaStreamDestroy(stream);
  }

  // State and scratch for width x height: the sizes optixDenoiserComputeMemoryResources
  // gives for a whole image (no tiles, so no overlap); one scratch buffer large
  // enough for setup, inference, intensity and average colour.
  void setup(int w, int h) {
    if (w == width && h == height) return;
    PN_OPTIX(optixDenoiserComputeMemoryResources(denoiser, unsigned(w), unsigned(h), &sizes));
    scratch_bytes = std::max({sizes.withoutOverlapScratchSizeInBytes, sizes.computeIntensitySizeInBytes,
                              sizes.computeAverageColorSizeInBytes});
    state.ensure(sizes.stateSizeInBytes, "the denoiser's state");
    scratch.ensure(scratch_bytes, "the denoiser's scratch memory");
    const size_t image = size_t(w) * size_t(h) * sizeof(float4);
    input.ensure(image, "the noisy image");
    albedo.ensure(image, "the albedo guide");
    normal.ensure(image, "the normal guide");
    output.ensure(image, "the denoised image");
    PN_OPTIX(optixDenoiserSetup(denoiser, stream, unsigned(w), unsigned(h), state.dptr(), sizes.stateSizeInBytes,
                                   scratch.dptr(), scratch_bytes));
    width = w;
    height = h;
  }

  // RGB floats -> a float4 device image (w = 0).
  void upload(const std::vector<float>& rgb, optix::DeviceBuffer& to) {
    const size_t pixels = size_t(width) * size_t(height);
    staging.resize(pixels);
    for (size_t i = 0; i < pixels; ++i) staging[i] = make_float4(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], 0.f);
    PN_CUDA(cudaMemcpyAsync(to.as<void>(), staging.data(), pixels * sizeof(float4), cudaMemcpyHostToDevice, stream));
    PN_CUDA(cudaStreamSynchronize(stream));  // staging is reused
  }
};

Denoiser::Denoiser(int device) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!optix_available(&why)) throw std::runtime_error("denoiser: " + why);
  Impl& d = *impl_;
  d.device = device;
  PN_CUDA(cudaSetDevice(device));
  PN_CUDA(cudaFree(nullptr));  // the primary context
  PN_CUDA(cudaStreamCreateWithFlags(&d.stream, cudaStreamNonBlocking));
  PN_CUDA(cudaEventCreate(&d.start));
  PN_CUDA(cudaEventCreate(&d.end));
  // OptiX's errors and warnings while the denoiser is made (the reason an
  // OPTIX_ERROR_INTERNAL_ERROR alone does not give), kept for the message.
  std::string log;
  OptixDeviceContextOptions co = {};
  co.logCallbackFunction = [](unsigned, const char* tag, const char* message, void* data) {
    std::string& l = *static_cast<std::string*>(data);
    if (l.size() < 1000) l += std::string(l.empty() ? "" : "; ") + "[" + tag + "] " + message;
  };
  co.logCallbackData = &log;
  co.logCallbackLevel = 3;  // errors and warnings
  PN_OPTIX(optixDeviceContextCreate(nullptr, &co, &d.context));
  OptixDenoiserOptions o = {};
  o.guideAlbedo = 1;
  o.guideNormal = 1;
  o.denoiseAlpha = OPTIX_DENOISER_ALPHA_MODE_COPY;
  const OptixResult r = optixDenoiserCreate(d.context, OPTIX_DENOISER_MODEL_KIND_AOV, &o, &d.denoiser);
  optixDeviceContextSetLogCallback(d.context, nullptr, nullptr, 0);  // `log` ends here
  if (r != OPTIX_SUCCESS) {
    std::string msg = std::string("denoiser: OptiX error in optixDenoiserCreate: ") + optixGetErrorName(r) + " (" +
                      optixGetErrorString(r) + ")";
    log = optix::one_line(log);
    if (!log.empty()) msg += ": " + log;
    // The network's weights are a file of the driver's (nvoptix.bin, beside its
    // libraries or in /usr/share/nvidia), which containers often leave out
    // (NVIDIA/nvidia-container-toolkit issue 127).
    if (r == OPTIX_ERROR_INTERNAL_ERROR || log.find("weights") != std::string::npos)
      msg += "; the driver's denoiser weights (nvoptix.bin, installed with the driver in /usr/share/nvidia) may be "
             "missing: in a container, mount it from the host";
    throw std::runtime_error(msg);
  }
  d.intensity.ensure(sizeof(float), "the denoiser's intensity");
  d.average.ensure(3 * sizeof(float), "the denoiser's average colour");
}

Denoiser::~Denoiser() = default;

float Denoiser::last_ms() const { return impl_->ms; }

std::vector<float> Denoiser::denoise(int width, int height, const std::vector<float>& rgb, const GuideImages& guides) {
  const size_t n = size_t(width) * size_t(height) * 3;
  if (width <= 0 || height <= 0 || rgb.size() != n || guides.width != width || guides.height != height ||
      guides.albedo.size() != n || guides.normal.size() != n)
    throw std::logic_error("denoiser: image and guides differ in size");
  Impl& d = *impl_;
  PN_CUDA(cudaSetDevice(d.device));
  d.setup(width, height);
  d.upload(rgb, d.input);
  d.upload(guides.albedo, d.albedo);
  d.upload(guides.normal, d.normal);

  const OptixImage2D input = float4_image(d.input, width, height);
  PN_CUDA(cudaEventRecord(d.start, d.stream));
  PN_OPTIX(optixDenoiserComputeIntensity(d.denoiser, d.stream, &input, d.intensity.dptr(), d.scratch.dptr(),
                                            d.scratch_bytes));
  PN_OPTIX(optixDenoiserComputeAverageColor(d.denoiser, d.stream, &input, d.average.dptr(), d.scratch.dptr(),
                                               d.scratch_bytes));
  OptixDenoiserParams params = {};
  params.hdrIntensity = d.intensity.dptr();
  params.hdrAverageColor = d.average.dptr();
  params.blendFactor = 0.f;  // all denoised
  params.temporalModeUsePreviousLayers = 0;
  OptixDenoiserGuideLayer guide = {};
  guide.albedo = float4_image(d.albedo, width, height);
  guide.normal = float4_image(d.normal, width, height);
  OptixDenoiserLayer layer = {};
  layer.input = input;
  layer.output = float4_image(d.output, width, height);
  layer.type = OPTIX_DENOISER_AOV_TYPE_BEAUTY;
  PN_OPTIX(optixDenoiserInvoke(d.denoiser, d.stream, &params, d.state.dptr(), d.sizes.stateSizeInBytes, &guide,
                                  &layer, 1, 0, 0, d.scratch.dptr(), d.scratch_bytes));
  PN_CUDA(cudaEventRecord(d.end, d.stream));
  const size_t pixels = size_t(width) * size_t(height);
  d.staging.resize(pixels);
  PN_CUDA(cudaMemcpyAsync(d.staging.data(), d.output.as<void>(), pixels * sizeof(float4), cudaMemcpyDeviceToHost,
                             d.stream));
  PN_CUDA(cudaStreamSynchronize(d.stream));
  PN_CUDA(cudaEventElapsedTime(&d.ms, d.start, d.end));
  std::vector<float> out(n);
  for (size_t i = 0; i < pixels; ++i) {
    out[3 * i] = d.staging[i].x;
    out[3 * i + 1] = d.staging[i].y;
    out[3 * i + 2] = d.staging[i].z;
  }
  return out;
}

}  // namespace pn
