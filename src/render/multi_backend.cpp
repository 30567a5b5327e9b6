#include "render/multi_backend.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace pn {
namespace {

// Thrown into a device's render by its progress hook once another device (or
// the caller's progress) has failed: it only stops that device.
struct Stopped {};

}  // namespace

MultiBackend::MultiBackend(std::vector<std::unique_ptr<Backend>> devices, std::vector<std::string> labels)
    : devices_(std::move(devices)), labels_(std::move(labels)) {
  if (devices_.empty()) throw std::logic_error("MultiBackend needs at least one device");
  labels_.resize(devices_.size());
  for (size_t i = 0; i < labels_.size(); ++i)
    if (labels_[i].empty()) labels_[i] = "device " + std::to_string(i);
  films_.resize(devices_.size());
}

std::string MultiBackend::name() const { return devices_.front()->name(); }

std::string MultiBackend::device_name() const {
  std::string labels;
  bool same = true;
  for (size_t i = 0; i < devices_.size(); ++i) {
    labels += (i ? ", " : "") + labels_[i];
    same = same && devices_[i]->device_name() == devices_[0]->device_name();
  }
  std::string out = std::to_string(devices_.size()) + " devices (" + labels + "): ";
  if (same) return out + devices_[0]->device_name();
  for (size_t i = 0; i < devices_.size(); ++i) out += (i ? "; " : "") + labels_[i] + " " + devices_[i]->device_name();
  return out;
}

std::vector<std::pair<std::string, std::string>> MultiBackend::device_info() const {
  auto info = devices_.front()->device_info();
  std::string labels;
  for (size_t i = 0; i < labels_.size(); ++i) labels += (i ? ", " : "") + labels_[i];
  info.emplace_back("devices", labels);
  return info;
}

std::vector<std::pair<uint32_t, uint32_t>> MultiBackend::split(uint32_t first, uint32_t count, size_t devices,
                                                               uint32_t granularity) {
  const uint64_t g = granularity ? granularity : 1;
  const uint64_t units = (uint64_t(count) + g - 1) / g;  // the last unit may be short
  std::vector<std::pair<uint32_t, uint32_t>> out;
  uint64_t unit = 0;
  for (size_t d = 0; d < devices; ++d) {
    const uint64_t n = units / devices + (d < units % devices ? 1 : 0);
    const uint64_t begin = std::min<uint64_t>(unit * g, count), end = std::min<uint64_t>((unit + n) * g, count);
    out.emplace_back(uint32_t(first + begin), uint32_t(end - begin));
    unit += n;
  }
  return out;
}

void MultiBackend::render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                          const ProgressFn& progress) {
  const int W = frame.camera.width, H = frame.camera.height;
  if (film.width() != W || film.height() != H) throw std::logic_error("film size differs from the camera's");
  const size_t n = devices_.size();
  const auto ranges = split(first_sample, count, n, split_granularity(frame, count));
  const uint64_t total = uint64_t(W) * H * count;
  stats_ = RenderStats();
  std::vector<DeviceTiming> timing(n);
  std::vector<RenderStats> device_stats(n);
  std::vector<uint64_t> done(n, 0);
  std::mutex mutex;  // guards done, stop, error and the calls of `progress`
  bool stop = false;
  std::exception_ptr error;
  auto fail = [&](std::exception_ptr e) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!error) error = e;
    stop = true;
  };

  auto run = [&](size_t d) {
    const auto [first, samples] = ranges[d];
    timing[d].device = labels_[d] + " " + devices_[d]->device_name();
    timing[d].first_sample = first;
    timing[d].count = samples;
    if (samples == 0) return;
    ProgressFn hook = [&, d](uint64_t device_done, uint64_t) {
      std::lock_guard<std::mutex> lock(mutex);
      if (stop) throw Stopped();
      done[d] = device_done;
      if (!progress) return;
      uint64_t all = 0;
      for (uint64_t x : done) all += x;
      try {
        progress(all, total);
      } catch (...) {
        if (!error) error = std::current_exception();
        stop = true;
        throw;
      }
    };
    auto t0 = std::chrono::steady_clock::now();
    try {
      films_[d].reset(W, H);
      devices_[d]->render(frame, films_[d], first, samples, hook);
    } catch (const Stopped&) {
      return;  // another device failed first
    } catch (...) {
      fail(std::current_exception());
      return;
    }
    timing[d].wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    device_stats[d] = devices_[d]->last_render_stats();
    for (const LaunchTiming& l : device_stats[d].launches) timing[d].gpu_ms += double(l.trace_ms) + l.accumulate_ms;
  };

  std::vector<std::thread> threads;
  try {
    for (size_t d = 1; d < n; ++d) threads.emplace_back(run, d);
  } catch (...) {  // no thread: stop those that started
    fail(std::current_exception());
  }
  run(0);
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);

  // The devices' sums, in device order for every value, by slices on as many
  // threads as devices (at 1080p, 25 M doubles a device).
  const size_t values = film.pixel_count() * 3, slice = (values + n - 1) / n;
  auto merge = [&](size_t k) {
    for (size_t d = 0; d < n; ++d)
      if (ranges[d].second > 0) film.add_values(films_[d], std::min(values, k * slice), std::min(values, (k + 1) * slice));
  };
  threads.clear();
  size_t started = 1;
  try {
    for (; started < n; ++started) threads.emplace_back(merge, started);
  } catch (...) {  // no thread: this one merges the rest
  }
  for (size_t k = started; k < n; ++k) merge(k);
  merge(0);
  for (std::thread& t : threads) t.join();
  film.add_samples(count);
  for (size_t d = 0; d < n; ++d) {
    stats_.launches.insert(stats_.launches.end(), device_stats[d].launches.begin(), device_stats[d].launches.end());
    stats_.rays += device_stats[d].rays;
    stats_.nonfinite += device_stats[d].nonfinite;
    for (const auto& p : device_stats[d].nonfinite_pixels) note_nonfinite_pixel(stats_, p[0], p[1], W);
  }
  stats_.devices = std::move(timing);
}

}  // namespace pn
