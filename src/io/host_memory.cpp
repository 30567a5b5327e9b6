#include "io/host_memory.h"

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

namespace pn {
namespace {

constexpr uint64_t kUnknown = std::numeric_limits<uint64_t>::max();

// A "Key:   123 kB" line of a /proc file, in bytes; kUnknown if absent.
uint64_t proc_kb(const char* file, const std::string& key) {
  std::ifstream f(file);
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key + ":", 0) == 0) {
      try {
        return uint64_t(std::stoull(line.substr(key.size() + 1))) * 1024;
      } catch (const std::exception&) {
        return kUnknown;
      }
    }
  return kUnknown;
}

// One number in a file (cgroup limits); kUnknown for "max" or anything else.
uint64_t file_number(const std::string& file) {
  std::ifstream f(file);
  std::string word;
  if (!(f >> word) || word.empty() || !std::isdigit(static_cast<unsigned char>(word[0]))) return kUnknown;
  try {
    return std::stoull(word);
  } catch (const std::exception&) {
    return kUnknown;
  }
}

// The cgroup (v2, else v1) this process is in: its limit minus its usage.
uint64_t cgroup_room() {
  std::ifstream f("/proc/self/cgroup");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("0::", 0) == 0) {  // v2: "0::/path"
      const std::string dir = "/sys/fs/cgroup" + line.substr(3);
      uint64_t max = file_number(dir + "/memory.max"), cur = file_number(dir + "/memory.current");
      if (max == kUnknown) max = file_number("/sys/fs/cgroup/memory.max");
      if (cur == kUnknown) cur = file_number("/sys/fs/cgroup/memory.current");
      if (max != kUnknown && cur != kUnknown) return max > cur ? max - cur : 0;
      return kUnknown;
    }
  }
  uint64_t max = file_number("/sys/fs/cgroup/memory/memory.limit_in_bytes");
  uint64_t cur = file_number("/sys/fs/cgroup/memory/memory.usage_in_bytes");
  if (max != kUnknown && cur != kUnknown && max < (uint64_t(1) << 60)) return max > cur ? max - cur : 0;
  return kUnknown;
}

uint64_t rlimit_room(int resource, const char* used_key) {
  rlimit rl{};
  if (getrlimit(resource, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) return kUnknown;
  uint64_t used = proc_kb("/proc/self/status", used_key);
  if (used == kUnknown) used = 0;
  return uint64_t(rl.rlim_cur) > used ? uint64_t(rl.rlim_cur) - used : 0;
}

}  // namespace

uint64_t available_memory(std::string* limit) {
  uint64_t best = kUnknown;
  std::string which = "unknown";
  auto consider = [&](uint64_t v, const char* name) {
    if (v < best) best = v, which = name;
  };
  consider(proc_kb("/proc/meminfo", "MemAvailable"), "MemAvailable");
  consider(cgroup_room(), "the cgroup's memory limit");
  consider(rlimit_room(RLIMIT_AS, "VmSize"), "the address-space limit, ulimit -v");
  consider(rlimit_room(RLIMIT_DATA, "VmData"), "the data-segment limit, ulimit -d");
  if (limit) *limit = which;
  return best;
}

std::string format_bytes(uint64_t b) {
  char buf[64];
  const double d = double(b);
  if (d >= 1024.0 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.1f GiB", d / (1024.0 * 1024 * 1024));
  else if (d >= 1024.0 * 1024) std::snprintf(buf, sizeof buf, "%.1f MiB", d / (1024.0 * 1024));
  else std::snprintf(buf, sizeof buf, "%.0f bytes", d);
  return buf;
}

void check_memory(const std::string& what, const std::vector<std::pair<std::string, uint64_t>>& parts) {
  uint64_t need = 0;
  for (const auto& p : parts) need += p.second;
  std::string limit;
  const uint64_t avail = available_memory(&limit);
  if (avail == kUnknown || need <= avail) return;
  std::string list;
  for (const auto& p : parts)
    if (p.second > 0) list += (list.empty() ? "" : ", ") + p.first + " " + format_bytes(p.second);
  throw std::runtime_error(what + " needs about " + format_bytes(need) + " of memory (" + list + "), but " +
                           format_bytes(avail) + " is available (" + limit + ")");
}

}  // namespace pn
