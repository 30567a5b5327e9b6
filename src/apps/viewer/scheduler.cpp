// The RenderScheduler (scheduler.h): the viewer's images, their restarts, and each frame's samples.
#include "apps/viewer/scheduler.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pn::viewer {

double RenderScheduler::seconds_since_restart() const {
  return ms_since(restart_time_) * 1e-3;
}

void RenderScheduler::restart(const ImageSettings& s, const FrameSpec& base, bool device_pixels,
                              const std::function<std::unique_ptr<ProgressiveImage>()>& make_image) {
  applied_ = s;
  started_ = true;
  restart_time_ = Clock::now();
  std::vector<std::unique_ptr<ProgressiveImage>> spare;
  for (Side& old : sides_) spare.push_back(std::move(old.image));
  auto make_side = [&](Strategy strategy, uint32_t seed) {
    Side side;
    if (!spare.empty() && spare.front() && spare.front()->writes_device_pixels() == device_pixels) {
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
  sides_.clear();
  if (!s.split) {
    sides_.push_back(make_side(s.integrator.strategy, base.seed));
  } else {
    sides_.push_back(make_side(s.left, base.seed));
    sides_.push_back(make_side(s.right, base.seed + 1));
  }
}

void RenderScheduler::clear() {
  sides_.clear();
  started_ = false;
}

RenderScheduler::Frame RenderScheduler::render(uint32_t spp, const Backend& backend) {
  Frame out;
  const auto t0 = Clock::now();
  std::vector<uint32_t> n(sides_.size(), spp);
  const bool measured =
      std::all_of(sides_.begin(), sides_.end(), [](const Side& s) { return s.image->samples() > 0; });
  if (applied_.split && applied_.equal_time && measured) {
    // Equal time: the target is the render time per pixel the side that is ahead reaches with `spp` more; the other
    // adds what its measured cost per sample needs to reach it (feedback on the totals, so one frame's timing noise
    // is corrected by the next). Both render the same pixels, so the costs compare the strategies.
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
    const auto ts = Clock::now();
    try {
      sides_[i].image->add_samples(n[i]);
    } catch (const std::invalid_argument& e) {  // settings this backend cannot render (restir's reuse on --megakernel)
      out.refused = e.what();
      continue;
    }
    sides_[i].seconds += ms_since(ts) * 1e-3;
    out.nonfinite += backend.last_render_stats().nonfinite;
  }
  out.ms = ms_since(t0);
  return out;
}

int RenderScheduler::divider_column(float divider) const {
  return applied_.split ? std::clamp(int(std::lround(divider * applied_.width)), 0, applied_.width) : applied_.width;
}

std::vector<float> RenderScheduler::composed_mean(float divider) const {
  if (sides_.size() == 1) return sides_[0].image->mean();
  const int W = applied_.width, H = applied_.height, d = divider_column(divider);
  std::vector<float> out = sides_[0].image->mean(), right = sides_[1].image->mean();
  for (int y = 0; y < H; ++y)
    std::copy_n(right.data() + (size_t(y) * W + d) * 3, size_t(W - d) * 3, out.data() + (size_t(y) * W + d) * 3);
  return out;
}

void RenderScheduler::write_mean_device(float* rgb, float divider) const {
  const int d = divider_column(divider);
  sides_[0].image->write_mean_device(rgb, 0, d);
  if (sides_.size() > 1) sides_[1].image->write_mean_device(rgb, d, applied_.width);
}

void RenderScheduler::tone_map(const DisplayPixels& px, float divider, float exposure) const {
  const int d = divider_column(divider);
  sides_[0].image->tone_map(px, 0, d, exposure);
  if (sides_.size() > 1) sides_[1].image->tone_map(px, d, applied_.width, exposure);
}

}  // namespace pn::viewer
