#include "objects.h"

#include <chrono>
#include <filesystem>
#include <stdexcept>

#include "backends/denoise.h"
#include "backends/make_backend.h"

#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#include "device_image.h"
#endif

namespace pn::py {
namespace {
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The document without what changes between frames: equal for two documents
// whose scenes differ only in frame settings.
json geometry_part(json doc) {
  if (doc.is_object()) {
    doc.erase("render");
    doc.erase("camera");
  }
  return doc;
}

}  // namespace

SceneState scene_from_name(const std::string& name_or_path, const std::vector<std::string>& overrides) {
  SceneState s;
  s.doc = load_scene_json(name_or_path, overrides, &s.source);
  s.scene = std::make_shared<const Scene>(load_scene(name_or_path, overrides));
  // As load_scene() resolves paths: built-in scenes hold absolute ones.
  std::filesystem::path p(name_or_path);
  s.base_dir = find_builtin(name_or_path) || !p.has_parent_path() ? "." : p.parent_path().string();
  return s;
}

SceneState scene_from_json(const json& doc, const std::string& source, const std::string& base_dir,
                           const std::vector<std::string>& overrides) {
  SceneState s;
  s.doc = doc;
  s.source = source;
  s.base_dir = base_dir;
  for (const auto& o : overrides) apply_override(s.doc, o, s.source);
  try {
    s.scene = std::make_shared<const Scene>(parse_scene(s.doc, s.source, s.base_dir));
  } catch (const json::exception& e) {  // as load_scene(): should not happen
    throw SceneError(s.source, "", e.what());
  }
  return s;
}

bool apply_overrides(SceneState& s, const std::vector<std::string>& overrides) {
  if (overrides.empty()) return false;
  json doc = s.doc;
  for (const auto& o : overrides) apply_override(doc, o, s.source);
  if (geometry_part(doc) == geometry_part(s.doc)) {
    SceneState next = s;
    next.doc = std::move(doc);
    frame_of(next);  // validates the frame settings
    s = std::move(next);
    return false;
  }
  s = scene_from_json(doc, s.source, s.base_dir, {});
  return true;
}

SceneState scene_with_overrides(const SceneState& s, const std::vector<std::string>& overrides) {
  SceneState t = s;
  apply_overrides(t, overrides);
  return t;
}

FrameSpec frame_of(const SceneState& s, RenderSettings* settings) {
  // A Scene holding only the frame settings: frame_spec() reads nothing else.
  Scene frame;
  frame.source = s.source;
  frame.camera = s.scene->camera;
  parse_frame_settings(s.doc, s.source, &frame.camera, &frame.render);
  if (settings) *settings = frame.render;
  return frame_spec(frame);
}

// --- ImageData ----------------------------------------------------------------------

void ImageData::ensure_host() {
  std::lock_guard<std::mutex> lock(host_mutex_);
  if (host_ready_) return;
  rgb_.resize(count());
  variance_.resize(count());
#if PN_HAVE_OPTIX
  if (device) device->download(rgb_.data(), variance_.data());
#endif
  host_ready_ = true;
}

const float* ImageData::rgb() {
  ensure_host();
  return rgb_.data();
}

const float* ImageData::variance() {
  ensure_host();
  return variance_.data();
}

// --- Renderer --------------------------------------------------------------------------

Renderer::Renderer(const SceneState& scene, std::string backend, int threads, std::string gpus,
                   const std::vector<std::string>& overrides, const GpuTuning& tuning)
    : scene_(scene_with_overrides(scene, overrides)), which_(std::move(backend)), threads_(threads),
      gpus_(std::move(gpus)), tuning_(tuning) {
  check_gpus(gpus_);
  if (which_ != "cpu" && which_ != "optix" && which_ != "auto")
    throw std::invalid_argument("unknown backend '" + which_ + "' (expected cpu, optix or auto)");
  frame_ = frame_of(scene_, &settings_);
  build();
  restart();
}

Renderer::~Renderer() = default;

void Renderer::build() {
  auto t0 = Clock::now();
  optix_ = nullptr;
  backend_.reset();  // the old one's device memory first
  BackendOptions opts;
  opts.threads = threads_;
  opts.gpus = gpus_;
  opts.tuning = tuning_;
  backend_ = make_backend(which_, *scene_.scene, opts, &note_);
#if PN_HAVE_OPTIX
  optix_ = dynamic_cast<OptixBackend*>(backend_.get());
#endif
  build_seconds_ = seconds_since(t0);
  ++builds_;
}

void Renderer::restart() {
  const int W = frame_.camera.width, H = frame_.camera.height;
  render_seconds_ = gpu_ms_ = 0;
  rays_ = 0;
  guides_ = GuideImages();
#if PN_HAVE_OPTIX
  if (optix_) {
    optix_->reset(frame_);
    return;
  }
#endif
  film_.reset(W, H);
}

void Renderer::update(const std::vector<std::string>& overrides) {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  SceneState next = scene_;
  const bool reparsed = apply_overrides(next, overrides);
  RenderSettings settings;
  FrameSpec frame = frame_of(next, &settings);
  scene_ = std::move(next);
  frame_ = frame;
  settings_ = settings;
  if (reparsed) build();  // geometry, lights or materials changed: the backend holds them
  restart();
}

void Renderer::render(uint32_t spp, const ProgressFn& progress) {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  auto t0 = Clock::now();
#if PN_HAVE_OPTIX
  if (optix_) {
    // On the device: the sums of every launch that started stay (a launch is
    // never cut short), so an interrupted render keeps them.
    optix_->accumulate(frame_, uint32_t(optix_->accumulated_samples()), spp, progress);
    render_seconds_ += seconds_since(t0);
    RenderStats st = optix_->last_render_stats();
    rays_ += st.rays;
    for (const auto& l : st.launches) gpu_ms_ += double(l.trace_ms) + l.accumulate_ms;
    return;
  }
#endif
  // Into a film of its own, added when complete: an interrupted render leaves
  // the accumulation as it was. Adding to zeros is exact, so one call gives the
  // bits of `penumbra render`.
  pass_.reset(film_.width(), film_.height());
  backend().render(frame_, pass_, uint32_t(film_.samples()), spp, progress);
  film_.add(pass_);
  render_seconds_ += seconds_since(t0);
  const RenderStats st = backend().last_render_stats();
  rays_ += st.rays;
  for (const auto& l : st.launches) gpu_ms_ += double(l.trace_ms) + l.accumulate_ms;
}

uint64_t Renderer::samples() const {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
#if PN_HAVE_OPTIX
  if (optix_) return optix_->accumulated_samples();
#endif
  return film_.samples();
}

Backend& Renderer::backend() const {
  if (!backend_) throw std::runtime_error(scene_.source + ": no backend: building it for the last change failed");
  return *backend_;
}

std::string Renderer::backend_name() const { return backend_ ? backend_->name() : "none"; }
std::string Renderer::device_name() const { return backend_ ? backend_->device_name() : "none"; }

void Renderer::reset() {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  restart();
}

json Renderer::stats() const {
  const uint64_t spp = samples();
  json s;
  s["backend"] = backend().name();
  s["device"] = backend().device_name();
  s["note"] = note_;
  s["scene"] = scene_.source;
  s["width"] = frame_.camera.width;
  s["height"] = frame_.camera.height;
  s["spp"] = spp;
  s["strategy"] = strategy_name(settings_.integrator.strategy);
  s["mis"] = mis_name(settings_.integrator.mis);
  s["mis_compensation"] = settings_.integrator.mis_compensation;
  s["light_selection"] = light_selection_name(settings_.integrator.light_selection);
  s["slc_cut"] = settings_.integrator.slc_cut;
  s["max_depth"] = settings_.integrator.max_depth;
  s["rr_depth"] = settings_.integrator.rr_depth;
  s["seed"] = settings_.seed;
  // Settings the document has that this list does not name (e.g. render.mis).
  if (scene_.doc.contains("render") && scene_.doc["render"].is_object())
    for (auto it = scene_.doc["render"].begin(); it != scene_.doc["render"].end(); ++it)
      if (!s.contains(it.key())) s[it.key()] = it.value();
  s["render_seconds"] = render_seconds_;
  s["build_seconds"] = build_seconds_;
  s["builds"] = builds_;
  const double samples = double(frame_.camera.width) * frame_.camera.height * double(spp);
  s["samples_per_second"] = render_seconds_ > 0 ? samples / render_seconds_ : 0.0;
  s["rays"] = rays_;  // 0: this backend does not count them
  if (optix_ || gpu_ms_ > 0) s["gpu_ms"] = gpu_ms_;
  // Several devices: each one's share of the last render() call.
  const RenderStats last = backend().last_render_stats();
  if (!last.devices.empty()) {
    json devices = json::array();
    for (const DeviceTiming& d : last.devices)
      devices.push_back({{"device", d.device}, {"first_sample", d.first_sample}, {"count", d.count},
                         {"wall_ms", d.wall_ms}, {"gpu_ms", d.gpu_ms}});
    s["devices"] = devices;
  }
  json info = json::object();
  for (const auto& [k, v] : backend().device_info()) info[k] = v;
  s["device_info"] = info;
  return s;
}

std::shared_ptr<ImageData> Renderer::image(bool denoise, const DenoiseOptions& options) {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  if (denoise) {
    check_denoise_choice("denoise=True", backend().name(), options);
    check_denoise_backend("denoise=True", backend(), options, note_);
  }
  auto img = std::make_shared<ImageData>();
  img->width = frame_.camera.width;
  img->height = frame_.camera.height;
  img->spp = samples();
  img->stats = stats();
#if PN_HAVE_OPTIX
  if (optix_) {
    img->device = DeviceImage::from_sums(optix_->device_sums(), optix_->device_sums_sq(), img->count(), img->spp,
                                         optix_->cuda_device());
  }
#endif
  if (!img->device) {
    img->rgb_ = film_.mean();
    img->variance_ = film_.variance_of_mean();
    img->host_ready_ = true;
  }
  if (denoise) {
    const auto t0 = Clock::now();
    if (guides_.width != img->width || guides_.height != img->height)
      guides_ = backend().render_guides(frame_, kGuideSamples);
    const double guide_ms = seconds_since(t0) * 1e3;
    const float* rgb = img->rgb();
    double denoise_ms = 0;
    std::string how;
    size_t repaired = 0;
    img->denoised = denoise_image(backend(), std::vector<float>(rgb, rgb + img->count()), guides_, options,
                                  &denoise_ms, &how, &repaired);
    img->stats["denoiser"] = how;
    img->stats["denoise_repaired"] = repaired;
    img->albedo = guides_.albedo;
    img->normal = guides_.normal;
    img->stats["denoise_ms"] = denoise_ms;
    img->stats["guide_ms"] = guide_ms;
    img->stats["guide_samples"] = kGuideSamples;
  }
  return img;
}

}  // namespace pn::py
