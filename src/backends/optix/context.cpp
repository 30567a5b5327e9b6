// The OptiX backend's context and driver checks (context.h).
#include "backends/optix/context.h"

#include <dlfcn.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include <optix_function_table_definition.h>
#include <optix_stubs.h>

namespace pn {
namespace optix {
namespace {

// "cudaMalloc(&p, n)" -> "cudaMalloc"
std::string call_name(const char* expr) {
  std::string s(expr);
  size_t paren = s.find('(');
  return paren == std::string::npos ? s : s.substr(0, paren);
}

}  // namespace

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

void check_cuda(cudaError_t e, const char* expr) {
  if (e == cudaSuccess) return;
  throw std::runtime_error("CUDA error in " + call_name(expr) + ": " + cudaGetErrorName(e) + " (" +
                           cudaGetErrorString(e) + ")");
}

void check_optix(OptixResult r, const char* expr, const char* log) {
  if (r == OPTIX_SUCCESS) return;
  std::string msg = "OptiX error in " + call_name(expr) + ": " + optixGetErrorName(r) + " (" +
                    optixGetErrorString(r) + ")";
  if (log && *log) msg += ": " + one_line(log);
  throw std::runtime_error(msg);
}

uint64_t device_memory_used() {
  size_t free_b = 0, total_b = 0;
  if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return uint64_t(total_b - free_b);
}

std::string optix_version_string(unsigned v) {
  return std::to_string(v / 10000) + "." + std::to_string((v % 10000) / 100) + "." + std::to_string(v % 100);
}

std::string driver_version() {
  std::ifstream f("/proc/driver/nvidia/version");
  std::string line;
  if (f && std::getline(f, line)) {
    std::istringstream words(line);
    // "NVRM version: NVIDIA UNIX [Open Kernel Module for] x86_64 Kernel Module  580.159.04  Release Build ..."
    std::string w;
    bool after_module = false;
    while (words >> w) {
      if (w == "Module") after_module = true;
      else if (after_module && std::isdigit((unsigned char)w[0]) && w.find('.') != std::string::npos) return w;
    }
  }
  if (void* nvml = dlopen("libnvidia-ml.so.1", RTLD_NOW | RTLD_LOCAL)) {
    using InitFn = int (*)();
    using VersionFn = int (*)(char*, unsigned);
    auto init = reinterpret_cast<InitFn>(dlsym(nvml, "nvmlInit_v2"));
    auto version = reinterpret_cast<VersionFn>(dlsym(nvml, "nvmlSystemGetDriverVersion"));
    auto shutdown = reinterpret_cast<InitFn>(dlsym(nvml, "nvmlShutdown"));
    char buf[96] = {0};
    std::string v;
    if (init && version && init() == 0) {
      if (version(buf, sizeof buf) == 0) v = buf;
      if (shutdown) shutdown();
    }
    dlclose(nvml);
    if (!v.empty()) return v;
  }
  return "unknown";
}

const Availability& availability() {
  static Availability a;
  static std::once_flag once;
  std::call_once(once, [] {
    int n = 0;
    cudaError_t e = cudaGetDeviceCount(&n);
    if (e == cudaErrorNoDevice || (e == cudaSuccess && n == 0)) {
      a.why = "no NVIDIA GPU found (cudaGetDeviceCount: no CUDA-capable device)";
      return;
    }
    if (e == cudaErrorInsufficientDriver) {
      if (void* libcuda = dlopen("libcuda.so.1", RTLD_NOW | RTLD_LOCAL)) {
        dlclose(libcuda);
      } else {
        a.why = "no NVIDIA driver found (libcuda.so.1 cannot be loaded)";
        return;
      }
      int rt = 0;
      cudaRuntimeGetVersion(&rt);
      a.why = "the NVIDIA driver is older than this build's CUDA runtime " + std::to_string(rt / 1000) +
              "." + std::to_string((rt % 1000) / 10) + " (cudaGetDeviceCount: " + cudaGetErrorString(e) + ")";
      return;
    }
    if (e != cudaSuccess) {
      a.why = std::string("no usable NVIDIA driver or GPU (cudaGetDeviceCount: ") + cudaGetErrorName(e) + ": " +
              cudaGetErrorString(e) + ")";
      return;
    }
    OptixResult r = optixInit();
    if (r == OPTIX_ERROR_UNSUPPORTED_ABI_VERSION) {
      a.why = "the NVIDIA driver (" + driver_version() + ") does not support the OptiX ABI this penumbra was built with: OptiX " +
              optix_version_string(OPTIX_VERSION) + " (ABI " + std::to_string(OPTIX_ABI_VERSION) +
              "); driver 580 supports up to OptiX 9.0 (ABI 105): rebuild with OptiX 9.0 headers (OptiX_ROOT) or update the driver";
      return;
    }
    if (r == OPTIX_ERROR_LIBRARY_NOT_FOUND || r == OPTIX_ERROR_ENTRY_SYMBOL_NOT_FOUND) {
      a.why = std::string("the NVIDIA driver has no usable OptiX library (libnvoptix.so.1): optixInit: ") +
              optixGetErrorName(r);
      return;
    }
    if (r != OPTIX_SUCCESS) {
      a.why = std::string("optixInit failed: ") + optixGetErrorName(r) + " (" + optixGetErrorString(r) + ")";
      return;
    }
    a.ok = true;
  });
  return a;
}

void log_callback(unsigned level, const char* tag, const char* message, void*) {
  std::fprintf(stderr, "optix: [%u][%s] %s\n", level, tag, one_line(message).c_str());
}

}  // namespace optix
}  // namespace pn
