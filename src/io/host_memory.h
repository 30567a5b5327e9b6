// The host memory this process may still use, and the one-line check made
// before a large allocation: where the need exceeds it, one line says both,
// instead of std::bad_alloc or a process killed by the kernel. What needs how
// much is estimated where it is known (render/resources.h: the film, images,
// the CPU backend; io/image_load.cpp: decoded images).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pn {

// Host memory this process may still allocate: the least of MemAvailable
// (/proc/meminfo), the cgroup's limit minus its usage, and the address-space
// and data limits (ulimit -v, -d) minus what the process already uses.
// `limit` receives which one it was, e.g. "MemAvailable". UINT64_MAX if unknown.
uint64_t available_memory(std::string* limit = nullptr);

// "12.3 GiB", "45.6 MiB", "789 bytes".
std::string format_bytes(uint64_t bytes);

// Throws std::runtime_error with one line when the parts of `what` need more
// than available_memory(): "<what> needs about N of memory (part a, part b, ...),
// but M is available (<limit>)".
void check_memory(const std::string& what, const std::vector<std::pair<std::string, uint64_t>>& parts);

}  // namespace pn
