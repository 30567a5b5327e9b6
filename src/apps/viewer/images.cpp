// The viewer's images from its controls (viewer_state.h): what they should be, light edits into the scene and
// the backend, restarts (the RenderScheduler's, scheduler.h, with the display's size), each frame's samples, and
// the denoised image.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/options.h"
#include "apps/viewer/viewer_state.h"
#include "io/image.h"
#include "render/oidn.h"

#if PN_VIEWER_INTEROP
#include "apps/viewer/device_image.h"
#include "backends/optix/optix_backend.h"
#endif

namespace pn::viewer {

ImageSettings Viewer::wanted() const {
  ImageSettings s;
  s.camera = camera_.desc();
  s.integrator = integrator_;
  RestirSettings& r = s.integrator.restir;
  if (integrator_.light_selection != LightSelection::Restir) r = scene_->render.integrator.restir;
  if (!r.unbiased) r.pairwise = 0;  // pairwise MIS is for the unbiased combination only
  int fw = 0, fh = 0;
  framebuffer_size(&fw, &fh);
  s.width = std::max(1, int(std::lround(fw * scale_)));
  s.height = std::max(1, int(std::lround(fh * scale_)));
  s.split = split_ && s.width >= 2;
  if (s.split) {
    s.left = left_;
    s.right = right_;
    s.equal_time = equal_time_;
  }
  s.light = light_;
  return s;
}

// Brings the images in line with the controls; restarts them when the image changes.
void Viewer::sync() {
  ImageSettings want = wanted();
  if (scheduler_.started() && want == scheduler_.applied()) return;
  if (!same(want.light, light_applied_)) {
    try {
      apply_light(want.light);
    } catch (const std::exception& e) {  // a value outside the scene format's limits: keep the last good light
      status_ = e.what();
      std::fprintf(stderr, "view: %s\n", e.what());
      light_ = light_applied_;
      want = wanted();
    }
  }
  restart(want);
}

// A light edit, into the scene in place and then the backend: Backend::update_lights where it can (the CPU:
// the meshes' acceleration structures are kept), else a new backend from the edited scene. Nothing is loaded.
void Viewer::apply_light(const LightEdit& e) {
  const auto t0 = Clock::now();
  set_sphere_light(*scene_, 0, e.center, e.radius, e.power);  // throws, the scene unchanged, on a bad value
  const bool in_place = backend_->update_lights();
  if (!in_place) make_backend_for_scene();
  light_applied_ = e;
  std::fprintf(stderr, "view: light changed in %.2f ms (%s)\n", ms_since(t0),
               in_place ? (backend_->name() + " backend updated in place").c_str()
                        : (backend_->name() + " backend made again from the edited scene").c_str());
}

void Viewer::restart(const ImageSettings& s) {
  FrameSpec base = frame_spec(*scene_);
  const CameraDesc& c = s.camera;
  base.camera = Camera::look_at(c.eye, c.target, c.up, c.fov, s.width, s.height);
  base.integrator = s.integrator;
  try {
    display_->resize(s.width, s.height);
  } catch (const std::exception& e) {  // registering the new size's pixel buffer with CUDA failed
    if (!display_->interop() || opt_.display == "interop") throw;
    display_->disable_interop();
    display_->resize(s.width, s.height);
    display_path_ = {DisplayPath::HostUpload, std::string("display: CUDA-OpenGL interop failed at ") +
                                                  std::to_string(s.width) + "x" + std::to_string(s.height) + " (" +
                                                  e.what() + "): falling back to host upload"};
    std::fprintf(stderr, "view: %s\n", display_path_.note.c_str());
  }
  scheduler_.restart(s, base, display_path_.path == DisplayPath::Interop, [&] { return make_image(); });
  guide_frame_ = base;
  guides_ = GuideImages();  // rendered again when next shown denoised
}

// This frame's samples (the scheduler's); returns the render time in ms. Samples that were NaN or infinite are
// left out by the backend: said once, and in the exit status.
double Viewer::render_samples() {
  const RenderScheduler::Frame f = scheduler_.render(uint32_t(spp_per_frame_), *backend_);
  if (!f.refused.empty()) status_ = f.refused;
  if (f.nonfinite > 0 && nonfinite_ == 0) {
    RenderStats st;
    st.nonfinite = f.nonfinite;
    std::fprintf(stderr, "warning: %s: %s\n", scene_->source.c_str(), describe_nonfinite(st).c_str());
    status_ = describe_nonfinite(st);
  }
  nonfinite_ += f.nonfinite;
  return f.ms;
}

// The denoise toggle: this frame's composed image, denoised. On the interop path
// where OIDN has a CUDA device for the GPU, nothing goes through host memory
// (show_denoised_on_device); else the mean is copied to the host, denoised there
// or by OIDN's CUDA device from host images, tone-mapped on the host and
// uploaded. False, and the toggle off with a status line, where it cannot run
// (Intel Open Image Denoise not installed: one line saying how to get it).
bool Viewer::show_denoised() {
  try {
    // Intel Open Image Denoise (backends/denoise.h), its library found once (apps/options.h).
    static const DenoiseOptions options = denoise_options(DenoiseArgs{});
    check_denoise_backend("denoise", *backend_, options);
    if (guides_.width != scheduler_.applied().width || guides_.height != scheduler_.applied().height) {
      guides_ = backend_->render_guides(guide_frame_, kGuideSamples);
      guides_on_device_ = false;
    }
    const std::string before = denoiser_;
    if (show_denoised_on_device(options)) {
      if (denoiser_ != before) std::fprintf(stderr, "view: denoise: %s\n", denoiser_.c_str());
      return true;
    }
    const std::vector<float> rgb =
        denoise_image(*backend_, scheduler_.composed_mean(divider_), guides_, options, &denoise_ms_, &denoiser_);
    if (denoiser_ != before) std::fprintf(stderr, "view: denoise: %s\n", denoiser_.c_str());
    const DisplayPixels px = display_->host_pixels();
    const float gain = std::exp2(exposure_);
    for (int y = 0; y < px.height; ++y) {
      unsigned char* row = px.data + size_t(y) * px.row_bytes;
      for (int x = 0; x < px.width; ++x) {
        const float* p = rgb.data() + (size_t(y) * px.width + x) * 3;
        for (int c = 0; c < 3; ++c) row[4 * x + c] = to_srgb8(p[c] * gain);
        row[4 * x + 3] = 255;
      }
    }
    display_->upload();
    return true;
  } catch (const std::exception& e) {
    status_ = e.what();
    std::fprintf(stderr, "view: %s\n", e.what());
    denoise_ = false;
    return false;
  }
}

// The interop path's denoise (device_image.h's DeviceDenoiser): the images' mean into a device image, OIDN's CUDA
// device on it in place, a kernel's tone-map into the mapped GL buffer. False where that path does not apply (host
// images, another backend, OIDN without a CUDA device for this GPU): the caller takes the host path.
bool Viewer::show_denoised_on_device(const DenoiseOptions& options) {
#if PN_VIEWER_INTEROP
  auto* optix = dynamic_cast<OptixBackend*>(backend_.get());
  if (!optix || !scheduler_.writes_device_pixels() || options.denoiser != DenoiserKind::Oidn) return false;
  Oidn& oidn = oidn_for(options.oidn_library);
  if (!oidn.cuda_supported(optix->cuda_device())) return false;
  if (!device_denoiser_) device_denoiser_ = std::make_shared<DeviceDenoiser>(optix->cuda_device());
  if (!guides_on_device_) {
    device_denoiser_->set_guides(guides_);
    guides_on_device_ = true;
  }
  scheduler_.write_mean_device(device_denoiser_->color(), divider_);
  OidnFilterOptions filter;
  filter.quality = options.quality;
  filter.clean_aux = options.clean_aux;
  denoise_ms_ = device_denoiser_->denoise(oidn, filter);
  denoiser_ = std::string("Intel Open Image Denoise, CUDA device, on the image in GPU memory, quality ") +
              denoise_quality_name(options.quality);
  const DisplayPixels px = display_->map_device_pixels();
  try {
    device_denoiser_->tone_map(px, exposure_);
  } catch (...) {
    display_->upload_mapped();  // unmapped again, for the raw frame the caller draws instead
    throw;
  }
  display_->upload_mapped();
  return true;
#else
  (void)options;
  return false;
#endif
}

}  // namespace pn::viewer
