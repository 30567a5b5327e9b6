// The state behind the Python module's objects, in plain C++ (no Python API):
// a scene as its document plus the parsed scene, a snapshot of an accumulated
// image, and a progressive renderer over one backend. module.cpp binds them.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/backend.h"
#include "backends/denoise.h"
#include "render/film.h"
#include "scene/scene.h"

namespace pn {
class OptixBackend;
}

namespace pn::py {

// A scene: the document after overrides (what Scene.to_dict() returns, and what
// further overrides apply to) and the scene parsed from it, which backends are
// built from. The frame settings (render, camera) are always read from `doc`.
struct SceneState {
  nlohmann::json doc;
  std::string source;    // "builtin:<name>", a file path, or "<dict>": names it in errors
  std::string base_dir;  // resolves the document's relative file paths
  std::shared_ptr<const Scene> scene;
};

// A built-in scene or a scene file, with "key=value" overrides. Throws SceneError.
SceneState scene_from_name(const std::string& name_or_path, const std::vector<std::string>& overrides);
// A scene document (relative paths resolved against base_dir). Throws SceneError.
SceneState scene_from_json(const nlohmann::json& doc, const std::string& source, const std::string& base_dir,
                           const std::vector<std::string>& overrides);
// Applies more overrides to `s`. When they change frame settings only (render,
// camera), the parsed scene is kept; otherwise the document is parsed again and
// true returned. Throws SceneError (and leaves `s` as it was).
bool apply_overrides(SceneState& s, const std::vector<std::string>& overrides);
SceneState scene_with_overrides(const SceneState& s, const std::vector<std::string>& overrides);

// The frame a document describes (camera, image size, integrator settings, seed).
FrameSpec frame_of(const SceneState& s, RenderSettings* settings = nullptr);

// The mean and variance of the mean of an accumulation, on the GPU
// (device_image.cu); a CPU-only build has none.
class DeviceImage;

// A snapshot of a renderer's image: what penumbra.Image holds.
class ImageData {
 public:
  int width = 0, height = 0;
  uint64_t spp = 0;
  nlohmann::json stats;
  std::shared_ptr<DeviceImage> device;  // GPU results, else null

  ImageData() = default;
  ImageData(const ImageData&) = delete;
  ImageData& operator=(const ImageData&) = delete;
  // Host copies, RGB interleaved, row 0 at the top (copied from the device on
  // first use for GPU results). The pointers stay valid as long as the image.
  const float* rgb();
  const float* variance();
  size_t count() const { return size_t(width) * height * 3; }

  // With image(true): the denoised mean and the denoiser's guides (core/aov.h),
  // host arrays of count() floats; empty otherwise.
  std::vector<float> denoised, albedo, normal;

 private:
  friend class Renderer;
  void ensure_host();
  std::mutex host_mutex_;
  bool host_ready_ = false;
  std::vector<float> rgb_, variance_;
};

// Samples accumulated progressively for one scene on one backend. Frame
// settings (strategy, depth, seed, size, camera) change without rebuilding the
// backend; anything else in the scene rebuilds it. Every change starts the
// accumulation over. Methods may be called from any thread, one at a time.
class Renderer {
 public:
  // `backend`: "cpu", "optix" or "auto"; `gpus`: --gpus ("all", "2", "0,2":
  // several GPUs split every render, and the image comes back through the host);
  // `overrides` apply to `scene` first; `tuning`: the GPU's (BackendOptions::tuning).
  // Throws SceneError, std::invalid_argument (a malformed `gpus`) or std::runtime_error.
  Renderer(const SceneState& scene, std::string backend, int threads, std::string gpus,
           const std::vector<std::string>& overrides, const GpuTuning& tuning = GpuTuning());
  ~Renderer();

  // Applies "key=value" overrides to the scene and restarts the accumulation.
  void update(const std::vector<std::string>& overrides);
  // Adds `spp` samples per pixel. An exception from `progress` stops the render;
  // the samples of completed calls (on the GPU: of completed launches) are kept.
  void render(uint32_t spp, const ProgressFn& progress);
  // A snapshot of the image; with `denoise`, also the image denoised by the
  // options' denoiser and its guides (std::runtime_error with one line where it
  // cannot run). The guides are rendered once per frame and kept until the
  // image starts over.
  std::shared_ptr<ImageData> image(bool denoise = false, const DenoiseOptions& options = {});
  void reset();

  uint64_t samples() const;
  const SceneState& scene() const { return scene_; }
  const RenderSettings& settings() const { return settings_; }
  std::string backend_name() const;
  std::string device_name() const;
  const std::string& note() const { return note_; }
  int builds() const { return builds_; }

 private:
  void build();
  void restart();
  Backend& backend() const;  // throws when the last build failed
  nlohmann::json stats() const;

  mutable std::recursive_mutex mutex_;
  SceneState scene_;
  RenderSettings settings_;
  FrameSpec frame_;
  std::string which_, note_;
  int threads_ = 0;
  std::string gpus_;
  GpuTuning tuning_;
  std::unique_ptr<Backend> backend_;
  OptixBackend* optix_ = nullptr;  // backend_ when it is one GPU: accumulation on the device
  Film film_, pass_;               // on the host (CPU, several GPUs): the accumulation, one call's samples
  int builds_ = 0;
  double build_seconds_ = 0, render_seconds_ = 0, gpu_ms_ = 0;
  uint64_t rays_ = 0;
  GuideImages guides_;  // of frame_, when guides_.width > 0
};

}  // namespace pn::py
