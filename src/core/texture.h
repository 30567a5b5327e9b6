// Image textures, looked up the same way on both backends: bilinear filtering
// between the four nearest texel centres, repeat wrapping, sRGB decoded to
// linear per texel BEFORE filtering (as a GPU's sRGB texture unit does).
//
// Texture coordinates follow the image convention of glTF: (0, 0) is the
// top-left corner of the image, v grows downwards, texel (i, j) has its centre
// at ((i + 0.5) / w, (j + 0.5) / h). Loaders convert other conventions (OBJ's
// v grows upwards: v_image = 1 - v_obj).
//
// On the GPU a texture is a CUDA texture object (`handle`) created with exactly
// these settings (linear filter, wrap, normalized coordinates); sRGB colour
// textures are decoded by srgb_to_linear on the host and uploaded as float, not
// decoded by the texture unit, whose sRGB curve differs (0.014% brighter
// direct light on Sponza). On the CPU `texels` points at the image, row 0 at
// the top. The GPU's filter weights have 8 fractional bits, the CPU's are
// exact: the two differ by at most 1/256 of a texel step, far below a pixel's
// noise and without bias over a texture.
#pragma once

#include "common.h"
#include "vec.h"

#if defined(__CUDACC__)
#include <cuda_runtime.h>
#endif

namespace pn {

enum class TexelFormat : uint32_t {
  Rgba8Srgb = 0,    // 8-bit colour, sRGB-encoded RGB, linear alpha (base colour, emission)
  Rgba8Linear = 1,  // 8-bit data (metallic-roughness, normal maps, alpha)
  Rgba32f = 2,      // float, linear (HDR environments)
};

struct TextureView {
  uint64_t handle = 0;            // GPU: cudaTextureObject_t; 0 on the CPU
  const void* texels = nullptr;   // CPU: width*height RGBA texels of `format`
  int32_t width = 0, height = 0;
  TexelFormat format = TexelFormat::Rgba8Srgb;
  bool nearest = false;           // nearest texel instead of bilinear (environments)
};

struct Rgba {
  Vec3 rgb;
  float a = 1.f;
};

// sRGB transfer function, decoding (IEC 61966-2-1).
PN_FN float srgb_to_linear(float c) {
  return c <= 0.04045f ? c * (1.f / 12.92f) : std::pow((c + 0.055f) * (1.f / 1.055f), 2.4f);
}

// An 8-bit sRGB value decoded: srgb_to_linear(v / 255), from a table on the host (the same floats, a lookup
// instead of a pow per channel and texel).
PN_FN float srgb8_to_linear(uint8_t v) {
#if defined(__CUDA_ARCH__)
  return srgb_to_linear(float(v) * (1.f / 255.f));
#else
  struct Table {
    float f[256];
    Table() {
      for (int i = 0; i < 256; ++i) f[i] = srgb_to_linear(float(i) * (1.f / 255.f));
    }
  };
  static const Table table;
  return table.f[v];
#endif
}

// One texel, wrapped, as linear RGBA (host side).
PN_FN Rgba texel_fetch(const TextureView& t, int x, int y) {
  x %= t.width;
  y %= t.height;
  if (x < 0) x += t.width;
  if (y < 0) y += t.height;
  const size_t i = size_t(y) * size_t(t.width) + size_t(x);
  Rgba r;
  if (t.format == TexelFormat::Rgba32f) {
    const float* p = static_cast<const float*>(t.texels) + 4 * i;
    r.rgb = Vec3(p[0], p[1], p[2]);
    r.a = p[3];
    return r;
  }
  const uint8_t* p = static_cast<const uint8_t*>(t.texels) + 4 * i;
  constexpr float k = 1.f / 255.f;
  if (t.format == TexelFormat::Rgba8Srgb)
    r.rgb = Vec3(srgb8_to_linear(p[0]), srgb8_to_linear(p[1]), srgb8_to_linear(p[2]));
  else
    r.rgb = Vec3(p[0] * k, p[1] * k, p[2] * k);
  r.a = p[3] * k;
  return r;
}

// Bilinear lookup at texture coordinates uv (repeat wrapping).
PN_FN Rgba texture_lookup(const TextureView& t, Vec2 uv) {
#if defined(__CUDA_ARCH__)
  float4 v = tex2D<float4>(cudaTextureObject_t(t.handle), uv.x, uv.y);
  Rgba r;
  r.rgb = Vec3(v.x, v.y, v.z);
  r.a = v.w;
  return r;
#else
  if (t.texels == nullptr || t.width <= 0 || t.height <= 0) return Rgba{Vec3(1.f), 1.f};
  if (t.nearest) {
    float x = uv.x * float(t.width), y = uv.y * float(t.height);
    if (!(std::isfinite(x) && std::isfinite(y))) return texel_fetch(t, 0, 0);
    x -= float(t.width) * std::floor(x / float(t.width));
    y -= float(t.height) * std::floor(y / float(t.height));
    return texel_fetch(t, int(x), int(y));
  }
  float x = uv.x * float(t.width) - 0.5f, y = uv.y * float(t.height) - 0.5f;
  if (!(std::isfinite(x) && std::isfinite(y))) return texel_fetch(t, 0, 0);
  float fx = std::floor(x), fy = std::floor(y);
  // Wrap the integer part into range first so that huge uv do not overflow int.
  float wx = fx - float(t.width) * std::floor(fx / float(t.width));
  float wy = fy - float(t.height) * std::floor(fy / float(t.height));
  int x0 = int(wx), y0 = int(wy);
  float ax = x - fx, ay = y - fy;
  Rgba a = texel_fetch(t, x0, y0), b = texel_fetch(t, x0 + 1, y0);
  Rgba c = texel_fetch(t, x0, y0 + 1), d = texel_fetch(t, x0 + 1, y0 + 1);
  Rgba r;
  r.rgb = (a.rgb * (1.f - ax) + b.rgb * ax) * (1.f - ay) + (c.rgb * (1.f - ax) + d.rgb * ax) * ay;
  r.a = (a.a * (1.f - ax) + b.a * ax) * (1.f - ay) + (c.a * (1.f - ax) + d.a * ax) * ay;
  return r;
#endif
}

}  // namespace pn
