// Progress of long work below the applications (converge's ground truth and
// runs): the work reports, whoever runs it decides how it is shown. The apps
// draw a bar on stderr (apps/progress.h, stderr_progress_bars); with no
// reporter nothing is shown.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace pn {

// One labelled part of the work, e.g. "reference 65536 spp".
class ProgressReport {
 public:
  virtual ~ProgressReport() = default;
  virtual void update(uint64_t done, uint64_t total) = 0;
  virtual void finish() = 0;  // the part is done: clear what was shown
};

// Makes the report of a part; may return nullptr (nothing to show).
using ProgressReporter = std::function<std::unique_ptr<ProgressReport>(const std::string& label)>;

// "12.3s", "4m05s", "2h10m".
std::string format_duration(double seconds);

}  // namespace pn
