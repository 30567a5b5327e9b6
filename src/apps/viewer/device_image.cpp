// The viewer's CUDA-OpenGL interop path: device-resident progressive images of
// the OptiX backend, and GL buffers registered with CUDA (device_image.h).
#include "apps/viewer/device_image.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <cuda_gl_interop.h>
#include <cuda_runtime.h>

#include "apps/viewer/device_image_kernels.h"
#include "backends/optix/optix_backend.h"

namespace pn::viewer {
namespace {

void check(cudaError_t e, const char* what) {
  if (e == cudaSuccess) return;
  throw std::runtime_error(std::string("CUDA error in ") + what + ": " + cudaGetErrorName(e) + " (" +
                           cudaGetErrorString(e) + ")");
}

template <class T>
struct DeviceArray {
  T* ptr = nullptr;
  size_t count = 0;
  DeviceArray() = default;
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() { release(); }
  void alloc(size_t n) {
    if (n == count) return;
    release();
    if (n == 0) return;
    check(cudaMalloc(reinterpret_cast<void**>(&ptr), n * sizeof(T)), "cudaMalloc (the viewer's image)");
    count = n;
  }
  void release() {
    if (ptr) cudaFree(ptr);  // never throws from a destructor
    ptr = nullptr;
    count = 0;
  }
};

class DeviceImage final : public ProgressiveImage {
 public:
  explicit DeviceImage(OptixBackend& backend) : backend_(backend) {
    check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
    thresholds_.alloc(255);
    check(cudaMemcpy(thresholds_.ptr, srgb8_thresholds(), 255 * sizeof(float), cudaMemcpyHostToDevice),
          "cudaMemcpy (the sRGB table)");
  }
  ~DeviceImage() override {
    if (stream_) cudaStreamSynchronize(stream_), cudaStreamDestroy(stream_);
  }

  void restart(const FrameSpec& frame) override {
    frame_ = frame;
    width_ = frame.camera.width;
    height_ = frame.camera.height;
    samples_ = 0;
    sum_.alloc(size_t(width_) * size_t(height_) * 3);
    check(cudaMemsetAsync(sum_.ptr, 0, sum_.count * sizeof(double), stream_), "cudaMemsetAsync");
    check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize");
  }

  void add_samples(uint32_t spp) override {
    if (spp == 0 || sum_.count == 0) return;
    // The backend's accumulation holds this call's samples only (the two sides
    // of the split screen share it); sample indices continue where the last
    // call stopped, so after N frames this is `render --spp N*spp` (as on the host path).
    backend_.reset(frame_);
    backend_.accumulate(frame_, uint32_t(samples_), spp);  // returns once the GPU is done
    check(launch_add_sums(sum_.ptr, backend_.device_sums(), sum_.count, stream_), "the add-sums kernel");
    check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize");  // before the backend's next reset
    samples_ += spp;
  }
  uint64_t samples() const override { return samples_; }
  int width() const override { return width_; }
  int height() const override { return height_; }
  bool writes_device_pixels() const override { return true; }

  void tone_map(const DisplayPixels& out, int x_begin, int x_end, float exposure) const override {
    if (!out.device) throw std::logic_error("device image asked to write host pixels");
    if (out.width != width_ || out.height != height_) throw std::logic_error("display size differs");
    const double inv = samples_ ? 1.0 / double(samples_) : 0.0;  // as on the host path, Film::mean()
    check(launch_tone_map_columns(sum_.ptr, width_, height_, x_begin, x_end, inv, std::exp2(exposure),
                                  thresholds_.ptr, out.data, out.row_bytes, stream_),
          "the tone-map kernel");
    check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize");  // done before GL reads the buffer
  }

  void write_mean_device(float* rgb, int x_begin, int x_end) const override {
    const double inv = samples_ ? 1.0 / double(samples_) : 0.0;
    check(launch_mean_columns(sum_.ptr, width_, height_, x_begin, x_end, inv, rgb, stream_), "the mean kernel");
    check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize");  // written before the denoiser reads it
  }

  std::vector<float> mean() const override {
    std::vector<double> sum(sum_.count);
    if (!sum.empty())
      check(cudaMemcpy(sum.data(), sum_.ptr, sum.size() * sizeof(double), cudaMemcpyDeviceToHost), "cudaMemcpy");
    std::vector<float> out(sum.size());
    const double inv = samples_ ? 1.0 / double(samples_) : 0.0;
    for (size_t i = 0; i < sum.size(); ++i) out[i] = float(sum[i] * inv);  // Film::mean()
    return out;
  }

 private:
  OptixBackend& backend_;
  FrameSpec frame_;
  int width_ = 0, height_ = 0;
  uint64_t samples_ = 0;
  cudaStream_t stream_ = nullptr;
  DeviceArray<double> sum_;
  DeviceArray<float> thresholds_;
};

}  // namespace

std::unique_ptr<ProgressiveImage> make_device_image(OptixBackend& backend) {
  return std::make_unique<DeviceImage>(backend);
}

struct DeviceDenoiser::Impl {
  int cuda_device = 0;
  int width = 0, height = 0;
  cudaStream_t stream = nullptr;
  DeviceArray<float> color, albedo, normal, output, thresholds;
};

DeviceDenoiser::DeviceDenoiser(int cuda_device) : impl_(std::make_unique<Impl>()) {
  impl_->cuda_device = cuda_device;
  check(cudaStreamCreateWithFlags(&impl_->stream, cudaStreamNonBlocking), "cudaStreamCreate");
  impl_->thresholds.alloc(255);
  check(cudaMemcpy(impl_->thresholds.ptr, srgb8_thresholds(), 255 * sizeof(float), cudaMemcpyHostToDevice),
        "cudaMemcpy (the sRGB table)");
}

DeviceDenoiser::~DeviceDenoiser() {
  if (impl_->stream) cudaStreamSynchronize(impl_->stream), cudaStreamDestroy(impl_->stream);
}

void DeviceDenoiser::set_guides(const GuideImages& guides) {
  Impl& m = *impl_;
  const size_t n = size_t(guides.width) * size_t(guides.height) * 3;
  if (guides.width <= 0 || guides.height <= 0 || guides.albedo.size() != n || guides.normal.size() != n)
    throw std::runtime_error("denoise: the guides are not images of " + std::to_string(guides.width) + " x " +
                             std::to_string(guides.height) + " pixels");
  m.width = guides.width;
  m.height = guides.height;
  for (DeviceArray<float>* a : {&m.color, &m.albedo, &m.normal, &m.output}) a->alloc(n);
  check(cudaMemcpy(m.albedo.ptr, guides.albedo.data(), n * sizeof(float), cudaMemcpyHostToDevice), "cudaMemcpy");
  check(cudaMemcpy(m.normal.ptr, guides.normal.data(), n * sizeof(float), cudaMemcpyHostToDevice), "cudaMemcpy");
}

float* DeviceDenoiser::color() { return impl_->color.ptr; }

double DeviceDenoiser::denoise(Oidn& oidn, const OidnFilterOptions& options) {
  const Impl& m = *impl_;
  OidnDeviceImages images;
  images.cuda_device = m.cuda_device;
  images.width = m.width;
  images.height = m.height;
  images.color = m.color.ptr;
  images.albedo = m.albedo.ptr;
  images.normal = m.normal.ptr;
  images.output = m.output.ptr;
  double ms = 0;
  oidn.denoise_device(images, options, &ms);
  return ms;
}

void DeviceDenoiser::tone_map(const DisplayPixels& out, float exposure) const {
  const Impl& m = *impl_;
  if (!out.device) throw std::logic_error("the device denoiser asked to write host pixels");
  if (out.width != m.width || out.height != m.height) throw std::logic_error("display size differs");
  check(launch_tone_map_rgb(m.output.ptr, m.width, m.height, std::exp2(exposure), m.thresholds.ptr, out.data,
                            out.row_bytes, m.stream),
        "the tone-map kernel");
  check(cudaStreamSynchronize(m.stream), "cudaStreamSynchronize");  // done before GL reads the buffer
}

CudaGlBuffer::CudaGlBuffer(unsigned gl_buffer) {
  cudaGraphicsResource_t r = nullptr;
  cudaError_t e = cudaGraphicsGLRegisterBuffer(&r, gl_buffer, cudaGraphicsRegisterFlagsWriteDiscard);
  if (e != cudaSuccess) {
    cudaGetLastError();  // not sticky: clear it
    throw std::runtime_error(std::string("cudaGraphicsGLRegisterBuffer: ") + cudaGetErrorName(e) + " (" +
                             cudaGetErrorString(e) + ")");
  }
  resource_ = r;
}

CudaGlBuffer::~CudaGlBuffer() {
  auto r = static_cast<cudaGraphicsResource_t>(resource_);
  if (mapped_) cudaGraphicsUnmapResources(1, &r, 0);
  if (r) cudaGraphicsUnregisterResource(r);
}

unsigned char* CudaGlBuffer::map(size_t* bytes) {
  auto r = static_cast<cudaGraphicsResource_t>(resource_);
  check(cudaGraphicsMapResources(1, &r, 0), "cudaGraphicsMapResources");
  mapped_ = true;
  void* p = nullptr;
  size_t n = 0;
  check(cudaGraphicsResourceGetMappedPointer(&p, &n, r), "cudaGraphicsResourceGetMappedPointer");
  if (bytes) *bytes = n;
  return static_cast<unsigned char*>(p);
}

void CudaGlBuffer::unmap() {
  if (!mapped_) return;
  auto r = static_cast<cudaGraphicsResource_t>(resource_);
  mapped_ = false;
  check(cudaGraphicsUnmapResources(1, &r, 0), "cudaGraphicsUnmapResources");
}

}  // namespace pn::viewer
