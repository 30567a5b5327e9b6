// Random numbers: PCG32 (O'Neill 2014) seeded per (pixel, sample index, seed).
//
// Every camera sample owns an independent stream derived by hashing its pixel
// index, sample index and the render seed. An image is therefore a pure function of
// (scene, settings, seed): the same on any number of CPU threads, and the same
// whether a pixel's samples are taken in one launch or in many (progressive).
#pragma once

#include "common.h"
#include "vec.h"

namespace pn {

// SplitMix64 finaliser: a bijective 64-bit mixer used to derive PCG seeds.
PN_FN uint64_t mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  PN_HD Rng() {}
  // Seeds the stream of one camera sample.
  PN_HD Rng(uint32_t pixel_index, uint32_t sample_index, uint32_t seed) {
    uint64_t key = (uint64_t(sample_index) << 32) | pixel_index;
    seed_pcg(mix64(key ^ mix64(seed)), mix64(uint64_t(seed) + 0x632be59bd9b4e019ull));
  }
  // The stream of pass `pass` of a frame-level computation (ReSTIR's spatial
  // reuse) at a pixel and sample: a seed above 2^32 in the hash, so that it is
  // never one of the camera samples' streams.
  PN_HD static Rng for_pass(uint32_t pixel_index, uint32_t sample_index, uint32_t seed, uint32_t pass) {
    Rng r;
    const uint64_t key = (uint64_t(sample_index) << 32) | pixel_index;
    const uint64_t s = uint64_t(seed) | ((uint64_t(pass) + 1u) << 32);
    r.seed_pcg(mix64(key ^ mix64(s)), mix64(s + 0x632be59bd9b4e019ull));
    return r;
  }
  PN_HD void seed_pcg(uint64_t initstate, uint64_t initseq) {
    state_ = 0u;
    inc_ = (initseq << 1u) | 1u;
    next_u32();
    state_ += initstate;
    next_u32();
  }
  PN_HD uint32_t next_u32() {
    uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  // Uniform in [0, 1): 24 random mantissa bits, exactly representable.
  PN_HD float uniform() { return float(next_u32() >> 8) * 0x1p-24f; }
  PN_HD Vec2 uniform2() {
    float a = uniform();
    return Vec2(a, uniform());
  }

 private:
  uint64_t state_ = 0x853c49e6748fea9bull;
  uint64_t inc_ = 0xda3e39cb94b95bdbull;
};

}  // namespace pn
