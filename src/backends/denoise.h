// Denoising a render: the backend's guides (core/aov.h) and a denoiser. Intel
// Open Image Denoise (render/oidn.h, loaded at run time) runs on every backend:
// its CPU device for the CPU backend, its CUDA device for the GPU backend where
// OIDN has one (else its CPU device, said in the note). The OptiX AI denoiser
// (backends/optix/denoiser.h) runs on the GPU backend only, where the driver's
// weights file exists. Every entry point says what is missing in one line
// (std::runtime_error) before any work.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "render/backend.h"
#include "render/oidn.h"

namespace pn {

// Camera rays per pixel the guides average (their jitter smooths edges as the image's box filter does).
constexpr uint32_t kGuideSamples = 8;

enum class DenoiserKind { Oidn, Optix };
const char* denoiser_name(DenoiserKind k);

struct DenoiseOptions {
  DenoiserKind denoiser = DenoiserKind::Oidn;
  DenoiseQuality quality = DenoiseQuality::High;  // OIDN's; the OptiX denoiser has one
  std::string oidn_library;  // libOpenImageDenoise's path (the apps find it); empty: the system's
  bool clean_aux = false;    // OIDN's cleanAux (see OidnFilterOptions)
};

// The options from their names as the command line and Python give them:
// denoiser "oidn" or "optix", quality "fast", "balanced" or "high"; another
// name throws std::invalid_argument naming it.
DenoiseOptions make_denoise_options(const std::string& denoiser, const std::string& quality, bool clean_aux = false,
                                    const std::string& oidn_library = "");

// Throws, with one line that starts with `what` ("--denoise", "denoise=True"),
// when `backend_choice` ("cpu", "optix", "auto") can never denoise with the
// options' denoiser: optix with "cpu" or in a build without the GPU backend;
// oidn where its library cannot be opened (the line says how to get it).
void check_denoise_choice(const std::string& what, const std::string& backend_choice,
                          const DenoiseOptions& options = {});

// Throws the same kind of line when `backend` (as made) cannot run the
// options' denoiser, e.g. optix when --backend auto fell back to the CPU; `why`
// adds the reason.
void check_denoise_backend(const std::string& what, const Backend& backend, const DenoiseOptions& options = {},
                           const std::string& why = "");

struct DenoisedImage {
  std::vector<float> rgb;  // the denoised image, width * height * 3
  GuideImages guides;      // the guides it was denoised with
  double guide_ms = 0;     // host clock around render_guides
  double denoise_ms = 0;   // the denoiser's time: GPU time (OptiX), host clock around the filter (OIDN)
  std::string how;         // e.g. "Intel Open Image Denoise, CPU device, quality high"
  size_t repaired = 0;     // pixels' values that were not finite, set to 0 before denoising (OIDN)
};

// Renders the frame's guides on `backend` (kGuideSamples rays a pixel) and
// denoises `mean` (the film's mean, width * height * 3) with them. OptiX's
// denoiser of each GPU and OIDN's devices are made once per process and kept.
// Throws std::runtime_error with one line.
DenoisedImage denoise_render(Backend& backend, const FrameSpec& frame, const std::vector<float>& mean,
                             const DenoiseOptions& options = {}, uint32_t guide_samples = kGuideSamples);

// Destroys the denoisers kept so far, and OIDN's kept filters (each made again on next use):
// a program that denoises once calls it before it exits, so that its device
// memory is freed before CUDA's own teardown (compute-sanitizer's leak check).
void release_denoisers();

// The same with guides already rendered (the viewer renders them once per view).
std::vector<float> denoise_image(Backend& backend, const std::vector<float>& mean, const GuideImages& guides,
                                 const DenoiseOptions& options = {}, double* denoise_ms = nullptr,
                                 std::string* how = nullptr, size_t* repaired = nullptr);

}  // namespace pn
