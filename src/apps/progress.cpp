#include "apps/progress.h"

#include <unistd.h>

#include <cstdio>

namespace pn {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)) {
  tty_ = isatty(STDERR_FILENO) == 1;
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

double ProgressBar::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressBar::update(uint64_t done, uint64_t total) {
  if (!tty_ || total == 0) return;
  auto now = std::chrono::steady_clock::now();
  if (done < total && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  double f = double(done) / double(total);
  double el = elapsed();
  double eta = f > 0 ? el * (1 - f) / f : 0;
  const int width = 30;
  int filled = int(f * width);
  std::string bar(filled, '#');
  bar += std::string(width - filled, '.');
  std::fprintf(stderr, "\r%s [%s] %5.1f%%  %llu/%llu samples  elapsed %s  ETA %s   ", label_.c_str(), bar.c_str(),
               100 * f, (unsigned long long)done, (unsigned long long)total, format_duration(el).c_str(),
               format_duration(eta).c_str());
  std::fflush(stderr);
  drawn_ = true;
}

namespace {

class BarReport : public ProgressReport {
 public:
  explicit BarReport(const std::string& label) : bar_(label) {}
  void update(uint64_t done, uint64_t total) override { bar_.update(done, total); }
  void finish() override { bar_.finish(); }

 private:
  ProgressBar bar_;
};

}  // namespace

ProgressReporter stderr_progress_bars() {
  return [](const std::string& label) -> std::unique_ptr<ProgressReport> { return std::make_unique<BarReport>(label); };
}

double ProgressBar::finish() {
  if (drawn_) {
    std::fprintf(stderr, "\r%*s\r", 120, "");
    std::fflush(stderr);
  }
  return elapsed();
}

}  // namespace pn
