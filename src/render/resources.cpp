#include "render/resources.h"

#include "core/restir.h"
#include "scene/scene.h"

namespace pn {

uint64_t film_bytes(int width, int height) { return uint64_t(width) * uint64_t(height) * 6 * sizeof(double); }

uint64_t image_write_bytes(int width, int height) {
  // The float image (12 bytes a pixel) and its encoding: EXR copies it into
  // planes (12) and tinyexr holds the compressed data twice while it
  // assembles the file (up to 2 x 12); PNG makes 8-bit pixels (3) and grows a
  // compressed stream (under 12). Measured: 5.6 GiB peak for a 1-spp 8192^2
  // EXR render, whose film and write this puts at 6.0 GiB.
  return uint64_t(width) * uint64_t(height) * (12 + 36);
}

uint64_t cpu_backend_bytes(const Scene& scene) {
  uint64_t bytes = 0;
  for (const TriangleMesh& m : scene.meshes)
    bytes += 160 * uint64_t(m.indices.size()) + 16 * uint64_t(m.positions.size());
  bytes += 512 * uint64_t(scene.instances.size()) + 64 * uint64_t(scene.spheres.size());
  bytes += scene.light_bvh.bytes();
  // restir's frame passes: a shading point and two reservoirs a pixel.
  if (restir_frame_passes(scene.integrator()))
    bytes += uint64_t(scene.render.width) * uint64_t(scene.render.height) * (sizeof(RestirPixel) + 2 * sizeof(Reservoir));
  return bytes;
}

}  // namespace pn
