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

// The denoise toggle: this frame's composed image, denoised, tone-mapped on the
// host and uploaded (the host path also under interop: the denoiser's output is
// a host image). False, and the toggle off with a status line, where it cannot
// run (Intel Open Image Denoise not installed: one line saying how to get it).
bool Viewer::show_denoised() {
  try {
    // Intel Open Image Denoise (backends/denoise.h), its library found once (apps/options.h).
    static const DenoiseOptions options = denoise_options(DenoiseArgs{});
    check_denoise_backend("denoise", *backend_, options);
    if (guides_.width != scheduler_.applied().width || guides_.height != scheduler_.applied().height)
      guides_ = backend_->render_guides(guide_frame_, kGuideSamples);
    const std::vector<float> rgb =
        denoise_image(*backend_, scheduler_.composed_mean(divider_), guides_, options, &denoise_ms_, &denoiser_);
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

}  // namespace pn::viewer
