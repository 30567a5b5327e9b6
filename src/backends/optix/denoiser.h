// The OptiX AI denoiser (part of the NVIDIA driver, reached through the OptiX
// headers the GPU backend already uses): a noisy HDR image and its albedo and
// normal guides (core/aov.h) in, the denoised image out.
//
// Model: OPTIX_DENOISER_MODEL_KIND_AOV with a single (beauty) layer. Since
// OptiX 8 the HDR kind is deprecated and mapped onto the AOV model anyway, and
// the HDR kind's normal guide had to be in camera space, where the AOV model
// takes the world-space normals our guides hold (NVIDIA recommends them on
// drivers R535 and later). Both its exposure inputs are computed per image:
// the log-average intensity (optixDenoiserComputeIntensity) and the log-average
// colour (optixDenoiserComputeAverageColor), so that a dim Cornell box and a
// bright sky are both brought to the range the network was trained on.
// Every image is FLOAT4 (RGB plus an unused channel) in device memory: the
// format every OptiX version accepts for inputs, guides and output alike.
//
// This header has no CUDA or OptiX types, so any C++ code may include it.
#pragma once

#include <memory>
#include <vector>

#include "render/backend.h"

namespace pn {

class Denoiser {
 public:
  // A denoiser on CUDA device `device`, with its own OptiX context and stream.
  // Throws std::runtime_error with one line (no GPU, no OptiX, a failed call).
  explicit Denoiser(int device);
  ~Denoiser();
  Denoiser(const Denoiser&) = delete;
  Denoiser& operator=(const Denoiser&) = delete;

  // Denoises rgb (width * height * 3 linear floats, row 0 at the top) guided by
  // `guides` of the same size. Device memory is set up again only when the
  // size changes. Throws std::runtime_error with one line.
  std::vector<float> denoise(int width, int height, const std::vector<float>& rgb, const GuideImages& guides);

  // GPU time of the last denoise() call (intensity, average colour, inference), from CUDA events.
  float last_ms() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pn
