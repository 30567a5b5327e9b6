// Denoising a render: the backend's guides (core/aov.h) and the OptiX AI
// denoiser (backends/optix/denoiser.h). The denoiser runs on the GPU only: on
// the CPU backend, or in a build without OptiX, every entry point here says so
// in one line (std::runtime_error) before any work.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "render/backend.h"

namespace pn {

// Camera rays per pixel the guides average (their jitter smooths edges as the image's box filter does).
constexpr uint32_t kGuideSamples = 8;

// Throws, with one line that starts with `what` ("--denoise", "denoise=True"),
// when `backend_choice` ("cpu", "optix", "auto") can never denoise: "cpu", or
// any choice in a build without the GPU backend.
void check_denoise_choice(const std::string& what, const std::string& backend_choice);

// Throws the same kind of line when `backend` (as made) is not the GPU
// backend, e.g. when --backend auto fell back to the CPU; `why` adds the reason.
void check_denoise_backend(const std::string& what, const Backend& backend, const std::string& why = "");

struct DenoisedImage {
  std::vector<float> rgb;  // the denoised image, width * height * 3
  GuideImages guides;      // the guides it was denoised with
  double guide_ms = 0;     // host clock around render_guides
  double denoise_ms = 0;   // GPU time of the denoiser
};

// Renders the frame's guides on `backend` (kGuideSamples rays a pixel) and
// denoises `mean` (the film's mean, width * height * 3) with them on the
// backend's GPU (device 0's of several). The denoiser of each GPU is made once
// per process and kept. Throws std::runtime_error with one line.
DenoisedImage denoise_render(Backend& backend, const FrameSpec& frame, const std::vector<float>& mean,
                             uint32_t guide_samples = kGuideSamples);

// Destroys the denoisers kept so far (each GPU's is made again on next use):
// a program that denoises once calls it before it exits, so that its device
// memory is freed before CUDA's own teardown (compute-sanitizer's leak check).
void release_denoisers();

// The same with guides already rendered (the viewer renders them once per view).
std::vector<float> denoise_image(Backend& backend, const std::vector<float>& mean, const GuideImages& guides,
                                 double* denoise_ms = nullptr);

}  // namespace pn
