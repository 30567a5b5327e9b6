// Progress reporting on stderr: a live bar when stderr is a terminal, nothing
// but the final summary otherwise (logs stay clean).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "render/progress.h"

namespace pn {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  // Thread-compatible: the caller serialises calls.
  void update(uint64_t done, uint64_t total);
  // Clears the bar; returns seconds since construction.
  double finish();
  double elapsed() const;
  bool interactive() const { return tty_; }

 private:
  std::string label_;
  bool tty_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
  bool drawn_ = false;
};

// A ProgressReporter (render/progress.h) that draws a ProgressBar per part.
ProgressReporter stderr_progress_bars();

}  // namespace pn
