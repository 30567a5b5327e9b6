// Memory estimates, checked before allocating: the film, the images written,
// the CPU backend's acceleration structures, decoded textures. Where the need
// exceeds what this process may still use, one line says both, instead of
// std::bad_alloc or a process killed by the kernel. (The GPU backend makes
// the same check against cudaMemGetInfo: backends/optix/optix_backend.cpp.)
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pn {

struct Scene;

// Host memory this process may still allocate: the least of MemAvailable
// (/proc/meminfo), the cgroup's limit minus its usage, and the address-space
// and data limits (ulimit -v, -d) minus what the process already uses.
// `limit` receives which one it was, e.g. "MemAvailable". UINT64_MAX if unknown.
uint64_t available_memory(std::string* limit = nullptr);

// Bytes of a Film of w x h pixels (per-pixel sums and sums of squares, double RGB).
uint64_t film_bytes(int width, int height);
// Peak bytes of writing one w x h image: the float image plus its encoding.
uint64_t image_write_bytes(int width, int height);
// The CPU backend's copy of the geometry and its Embree BVHs (measured on the
// built-in scenes: 40-135 bytes a triangle, about 330 an instance; this errs high),
// the light BVH, and restir's per-pixel buffers where the scene's settings use them.
uint64_t cpu_backend_bytes(const Scene& scene);

// "12.3 GiB", "45.6 MiB", "789 bytes".
std::string format_bytes(uint64_t bytes);

// Throws std::runtime_error with one line when the parts of `what` need more
// than available_memory(): "<what> needs about N of memory (part a, part b, ...),
// but M is available (<limit>)".
void check_memory(const std::string& what, const std::vector<std::pair<std::string, uint64_t>>& parts);

}  // namespace pn
