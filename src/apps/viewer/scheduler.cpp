// The viewer's images (viewer_state.h): what they should be from the controls,
// restarts when that changes, each frame's samples (one image, or two sides at
// equal samples or equal time), the composed and the denoised image.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/options.h"
#include "apps/viewer/viewer_state.h"
#include "backends/make_backend.h"
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

int Viewer::divider_column() const {
  return applied_.split ? std::clamp(int(std::lround(divider_ * applied_.width)), 0, applied_.width) : applied_.width;
}

// Brings the images in line with the controls; restarts them when the image changes.
void Viewer::sync() {
  ImageSettings want = wanted();
  if (started_ && want == applied_) return;
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
  if (!in_place) {
    sides_.clear();
    backend_.reset();
    std::string note;
    backend_ = make_backend(opt_.backend, *scene_, opt_.backend_options, &note);
    ++backend_builds_;
  }
  light_applied_ = e;
  std::fprintf(stderr, "view: light changed in %.2f ms (%s)\n", ms_since(t0),
               in_place ? (backend_->name() + " backend updated in place").c_str()
                        : (backend_->name() + " backend made again from the edited scene").c_str());
}

void Viewer::restart(const ImageSettings& s) {
  applied_ = s;
  started_ = true;
  restart_time_ = Clock::now();
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

  // The images of the last restart are reused (same backend: load() clears
  // them): a device image keeps its GPU buffers while the camera moves.
  std::vector<std::unique_ptr<ProgressiveImage>> spare;
  for (Side& old : sides_) spare.push_back(std::move(old.image));
  const bool device = display_path_.path == DisplayPath::Interop;
  auto make_side = [&](Strategy strategy, uint32_t seed) {
    Side side;
    if (!spare.empty() && spare.front() && spare.front()->writes_device_pixels() == device) {
      side.image = std::move(spare.front());
      spare.erase(spare.begin());
    } else {
      side.image = make_image();
    }
    side.strategy = strategy;
    FrameSpec f = base;
    f.integrator.strategy = strategy;
    f.seed = seed;
    side.image->restart(f);
    return side;
  };
  guide_frame_ = base;
  guides_ = GuideImages();  // rendered again when next shown denoised
  sides_.clear();
  if (!s.split) {
    sides_.push_back(make_side(s.integrator.strategy, base.seed));
  } else {
    // The right side gets its own seed, so that the two sides' errors are
    // independent (and equal strategies show a seam: they are two estimates).
    sides_.push_back(make_side(s.left, base.seed));
    sides_.push_back(make_side(s.right, base.seed + 1));
  }
}

// Adds this frame's samples; returns the render time in ms.
double Viewer::render_samples() {
  auto t0 = Clock::now();
  const uint32_t spp = uint32_t(spp_per_frame_);
  std::vector<uint32_t> n(sides_.size(), spp);
  bool measured = std::all_of(sides_.begin(), sides_.end(), [](const Side& s) { return s.image->samples() > 0; });
  if (applied_.split && applied_.equal_time && measured) {
    // Equal time: both images get the same render time. The one that is ahead
    // adds `spp`; the other catches up at its own measured cost per sample
    // (feedback on the totals, so one frame's timing noise is corrected by the
    // next). Both render the same pixels, so the costs compare the strategies.
    double target = 0;
    std::vector<double> tpp(sides_.size()), cost(sides_.size());
    for (size_t i = 0; i < sides_.size(); ++i) {
      tpp[i] = sides_[i].seconds_per_pixel();
      cost[i] = tpp[i] / double(sides_[i].image->samples());
      target = std::max(target, tpp[i] + spp * cost[i]);
    }
    for (size_t i = 0; i < sides_.size(); ++i)
      n[i] = cost[i] > 0 ? uint32_t(std::clamp(std::lround((target - tpp[i]) / cost[i]), 0l, 64l * spp)) : spp;
  }
  for (size_t i = 0; i < sides_.size(); ++i) {
    auto ts = Clock::now();
    try {
      sides_[i].image->add_samples(n[i]);
    } catch (const std::invalid_argument& e) {  // settings this backend cannot render (restir's reuse on --megakernel)
      status_ = e.what();
      continue;
    }
    sides_[i].seconds += ms_since(ts) * 1e-3;
    // Samples that were NaN or infinite: left out by the backend; said once, and in the exit status.
    const RenderStats st = backend_->last_render_stats();
    if (st.nonfinite > 0 && nonfinite_ == 0) {
      std::fprintf(stderr, "warning: %s: %s\n", scene_->source.c_str(), describe_nonfinite(st).c_str());
      status_ = describe_nonfinite(st);
    }
    nonfinite_ += st.nonfinite;
  }
  return ms_since(t0);
}

std::vector<float> Viewer::composed_mean() const {
  if (sides_.size() == 1) return sides_[0].image->mean();
  const int W = applied_.width, H = applied_.height, d = divider_column();
  std::vector<float> out = sides_[0].image->mean(), right = sides_[1].image->mean();
  for (int y = 0; y < H; ++y)
    std::copy_n(right.data() + (size_t(y) * W + d) * 3, size_t(W - d) * 3, out.data() + (size_t(y) * W + d) * 3);
  return out;
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
    if (guides_.width != applied_.width || guides_.height != applied_.height)
      guides_ = backend_->render_guides(guide_frame_, kGuideSamples);
    const std::vector<float> rgb =
        denoise_image(*backend_, composed_mean(), guides_, options, &denoise_ms_, &denoiser_);
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
