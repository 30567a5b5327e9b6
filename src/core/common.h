// penumbra core: compilation helpers shared by host C++ and CUDA device code.
//
// Everything under src/core/ is header-only and must compile both as plain C++17
// and as CUDA device code. Functions that run on both sides are marked PN_HD.
// No exceptions, no virtual functions, no allocation, no std:: containers here.
#pragma once

#include <cmath>
#include <cstdint>

#if defined(__CUDACC__)
#define PN_HD __host__ __device__
#define PN_INLINE __forceinline__
#else
#define PN_HD
#define PN_INLINE inline
#endif

#define PN_FN PN_HD PN_INLINE
// A large function the GPU calls rather than inlines at every call site: one copy a kernel, not one a caller
// (the compile time of kernels that hold every strategy).
#if defined(__CUDACC__)
#define PN_FN_CALLED __host__ __device__ __noinline__ inline
#else
#define PN_FN_CALLED inline
#endif

namespace pn {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kTwoPi = 6.28318530717958647692f;
constexpr float kInvPi = 0.31830988618379067154f;
constexpr float kInvTwoPi = 0.15915494309189533577f;
constexpr float kInvFourPi = 0.07957747154594766788f;
constexpr float kInf = 3.402823466e+38f;  // FLT_MAX; a "miss" distance
// Largest float strictly below 1: keeps u in [0,1) after float rounding.
constexpr float kOneMinusEpsilon = 0.99999994f;

template <typename T>
PN_FN T pn_min(T a, T b) { return a < b ? a : b; }
template <typename T>
PN_FN T pn_max(T a, T b) { return a > b ? a : b; }
template <typename T>
PN_FN T clamp(T v, T lo, T hi) { return v < lo ? lo : (v > hi ? hi : v); }

PN_FN float sqr(float x) { return x * x; }
// sqrt that returns 0 for slightly negative inputs caused by rounding.
PN_FN float safe_sqrt(float x) { return std::sqrt(pn_max(0.f, x)); }
// 1 / sqrt(x) for x > 0: one instruction on the GPU (rsqrtf, within 2 ulp), 1 / std::sqrt on the host.
PN_FN float pn_rsqrt(float x) {
#ifdef __CUDA_ARCH__
  return rsqrtf(x);
#else
  return 1.f / std::sqrt(x);
#endif
}

}  // namespace pn
