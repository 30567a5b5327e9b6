// The OptiX backend's context and driver checks: one-line errors for every CUDA
// and OptiX call, whether this machine can run OptiX at all (checked once per
// process), the driver's version, and the OptiX log callback.
// Internal to the backend (CUDA and OptiX types); optix_backend.h is the interface.
#pragma once

#include <cstdint>
#include <string>

#include <cuda_runtime.h>
#include <optix.h>

namespace pn {
namespace optix {

// Throw std::runtime_error with one line: "CUDA error in cudaMalloc: ..." (a
// call's name is its expression up to the first parenthesis), OptiX's with its
// compile log appended on one line.
void check_cuda(cudaError_t e, const char* expr);
void check_optix(OptixResult r, const char* expr, const char* log = nullptr);
#define PN_CUDA(call) ::pn::optix::check_cuda((call), #call)
#define PN_OPTIX(call) ::pn::optix::check_optix((call), #call)
#define PN_OPTIX_LOG(call, log) ::pn::optix::check_optix((call), #call, (log))

std::string one_line(std::string s);  // newlines to spaces, trailing spaces removed

// Whether a GPU, its driver and OptiX can be used (optixInit done), else why, in
// one line: no GPU, no driver, a driver older than the CUDA runtime, an OptiX
// ABI the driver does not speak. Checked once per process.
struct Availability {
  bool ok = false;
  std::string why;
};
const Availability& availability();

std::string driver_version();                  // "580.159.04": the kernel module's, else NVML's; "unknown"
std::string optix_version_string(unsigned v);  // 90000 -> "9.0.0"
uint64_t device_memory_used();                 // device-wide (all processes), cudaMemGetInfo; 0 if unknown

// OptixDeviceContextOptions::logCallbackFunction: one line on stderr.
void log_callback(unsigned level, const char* tag, const char* message, void*);

}  // namespace optix
}  // namespace pn
