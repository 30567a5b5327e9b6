#include "apps/viewer/progressive.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "apps/viewer/tone_map.h"
#include "io/image.h"

namespace pn::viewer {
namespace {

// kThreshold[k - 1] is the smallest float v with to_srgb8(v) >= k, found by
// bisection over the ordered bit patterns of positive floats; to_srgb8 is
// monotonic, so counting thresholds <= v gives exactly to_srgb8(v).
const std::array<float, 255>& thresholds() {
  static const std::array<float, 255> table = [] {
    std::array<float, 255> t{};
    for (int k = 1; k <= 255; ++k) {
      uint32_t lo = 0, hi = 0x3f800000u;  // bit patterns of 0 and 1.0f; to_srgb8(1) = 255
      while (lo + 1 < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        float v;
        std::memcpy(&v, &mid, sizeof v);
        (to_srgb8(v) >= k ? hi : lo) = mid;
      }
      std::memcpy(&t[k - 1], &hi, sizeof(float));
    }
    return t;
  }();
  return table;
}

class HostImage final : public ProgressiveImage {
 public:
  explicit HostImage(Backend& backend) : backend_(backend) {}

  void restart(const FrameSpec& frame) override {
    frame_ = frame;
    film_.reset(frame.camera.width, frame.camera.height);
  }
  void add_samples(uint32_t spp) override {
    if (spp == 0 || film_.pixel_count() == 0) return;
    // Sample indices continue where the last call stopped: after N frames the
    // film holds samples 0..N*spp-1, the image `render --spp N*spp` makes.
    backend_.render(frame_, film_, uint32_t(film_.samples()), spp);
  }
  uint64_t samples() const override { return film_.samples(); }
  int width() const override { return film_.width(); }
  int height() const override { return film_.height(); }

  void tone_map(const DisplayPixels& out, int x_begin, int x_end, float exposure) const override {
    if (out.device) throw std::logic_error("host image asked to write device pixels");
    if (out.width != film_.width() || out.height != film_.height()) throw std::logic_error("display size differs");
    x_begin = std::max(x_begin, 0);
    x_end = std::min(x_end, film_.width());
    const int h = film_.height();
    // The same arithmetic as Film::mean() followed by write_image's exposure,
    // so the screen shows exactly the bytes of a PNG screenshot.
    const double inv = film_.samples() ? 1.0 / double(film_.samples()) : 0.0;
    const float gain = std::exp2(exposure);
    const double* sum = film_.sum();
    const float* t = srgb8_thresholds();
    for (int y = 0; y < h; ++y) {
      unsigned char* row = out.data + size_t(y) * out.row_bytes;
      const double* s = sum + size_t(y) * film_.width() * 3;
      for (int x = x_begin; x < x_end; ++x) tone_map_pixel(s + 3 * x, inv, gain, t, row + 4 * x);  // tone_map.h
    }
  }

  std::vector<float> mean() const override { return film_.mean(); }

 private:
  Backend& backend_;
  FrameSpec frame_;
  Film film_;
};

}  // namespace

unsigned char srgb8_fast(float v) { return srgb8_by_thresholds(v, thresholds().data()); }

const float* srgb8_thresholds() { return thresholds().data(); }

void ProgressiveImage::write_mean_device(float*, int, int) const {
  throw std::logic_error("write_mean_device() on an image in host memory");
}

const char* display_path_name(DisplayPath path) {
  return path == DisplayPath::Interop ? "CUDA-OpenGL interop" : "host upload";
}

DisplayChoice choose_display_path(const std::string& mode, const std::string& backend, bool interop_built,
                                  const std::function<std::string()>& try_interop) {
  const std::string hint = "; use --display host, or `penumbra render` to render to a file";
  DisplayChoice c;
  if (mode == "host") {
    c.note = "display: host upload (--display host): the image is copied to host memory and uploaded every frame";
    return c;
  }
  if (mode != "auto" && mode != "interop") throw std::invalid_argument("--display must be auto, interop or host");
  std::string why;
  if (backend != "optix") why = "the " + backend + " backend renders in host memory";
  else if (!interop_built) why = "this penumbra was built without CUDA (no OptiX backend)";
  else why = try_interop();
  if (why.empty()) {
    c.path = DisplayPath::Interop;
    c.note = "display: CUDA-OpenGL interop: the image stays on the GPU (tone-mapped by CUDA into a GL pixel buffer)";
    return c;
  }
  if (mode == "interop") throw std::runtime_error("--display interop: not available: " + why + hint);
  c.note = backend == "optix" ? "display: CUDA-OpenGL interop unavailable (" + why +
                                    "): falling back to host upload (the GPU's image is copied through host memory "
                                    "every frame)"
                              : "display: host upload (" + why + ")";
  return c;
}

std::unique_ptr<ProgressiveImage> make_host_image(Backend& backend) { return std::make_unique<HostImage>(backend); }

}  // namespace pn::viewer
