// One image on several devices: a Backend over backends of the same scene (one
// per GPU, or, in the tests, several CPU backends), each rendering a disjoint
// range of the samples of every pixel on a host thread of its own, into a film
// of its own; the films' sums are then added in device order, in double.
//
// Sample i of a pixel is the same path on any device (core/rng.h: the stream is
// a function of pixel, sample index and seed), so the split changes nothing but
// the order in which double sums are added: where a range holds whole launches
// of the single device (split_granularity) the float image is the one device's
// image (tests/backends/test_render.cpp checks it bit for bit on CPU "devices").
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "render/backend.h"

namespace pn {

class MultiBackend final : public Backend {
 public:
  // `devices` (at least one) must render the same scene; device i is named
  // `labels[i]` in device_name() (e.g. "GPU 1"), or by its index.
  explicit MultiBackend(std::vector<std::unique_ptr<Backend>> devices, std::vector<std::string> labels = {});

  std::string name() const override;         // the devices' backend: "optix"
  std::string device_name() const override;  // "2 GPUs: NVIDIA H200 (GPU 0), NVIDIA H200 (GPU 1)"
  // Device 0 renders on the calling thread, every other device on a thread of
  // its own. `progress` sees the samples of all devices (calls serialised); an
  // exception from it, or from any device, stops every device and leaves
  // render() with `film` unchanged.
  void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
              const ProgressFn& progress = nullptr) override;
  // Launches of every device (in device order), rays summed, and `devices`:
  // each device's samples and times.
  RenderStats last_render_stats() const override { return stats_; }
  bool update_lights() override {  // every device's, or false (the caller then makes a new backend)
    for (auto& d : devices_)
      if (!d->update_lights()) return false;
    return true;
  }
  std::vector<std::pair<std::string, std::string>> device_info() const override;
  SceneBuildStats scene_build_stats() const override { return devices_.front()->scene_build_stats(); }
  uint32_t split_granularity(const FrameSpec& frame, uint32_t count) const override {
    return devices_.front()->split_granularity(frame, count);
  }
  // Device 0's: the guides are cheap next to the samples.
  GuideImages render_guides(const FrameSpec& frame, uint32_t samples) override {
    return devices_.front()->render_guides(frame, samples);
  }
  // Device 0, for what runs on one GPU after the render (the denoiser).
  Backend& first_device() const { return *devices_.front(); }

  size_t device_count() const { return devices_.size(); }

  // The sample ranges of `count` samples from `first` on `devices` devices, as
  // render() splits them: whole multiples of `granularity` (the last range of
  // the split takes the remainder), as equal as they can be, in device order;
  // a device may get none. Pairs of (first sample, count).
  static std::vector<std::pair<uint32_t, uint32_t>> split(uint32_t first, uint32_t count, size_t devices,
                                                          uint32_t granularity);

 private:
  std::vector<std::unique_ptr<Backend>> devices_;
  std::vector<std::string> labels_;
  std::vector<Film> films_;  // one per device, kept between calls
  RenderStats stats_;
};

}  // namespace pn
