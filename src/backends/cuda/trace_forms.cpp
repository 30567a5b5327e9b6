#include "backends/cuda/trace_forms.h"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "backends/cuda/bvh_traverse.h"

namespace pn {

CudaTraceForms choose_trace_forms(bool flat, double sah_visits_per_ray) {
  auto setting = [](const char* name, const char* values) {
    const char* env = std::getenv(name);
    const std::string v = env ? env : "auto";
    if (("|" + std::string(values) + "|").find("|" + v + "|") == std::string::npos)
      throw std::runtime_error(std::string(name) + " must be " + values + ", not '" + v + "'");
    return v;
  };
  const std::string loop = setting("PENUMBRA_CUDA_LOOP", "auto|while|ifif");
  const std::string box = setting("PENUMBRA_CUDA_BOX", "auto|slab|fma");
  const std::string flat_setting = setting("PENUMBRA_CUDA_FLAT", "auto|0");
  CudaTraceForms f;
  char buf[200];
  const bool if_if = loop == "auto" ? sah_visits_per_ray >= kIfIfMinVisits : loop == "ifif";
  if (loop == "auto")
    std::snprintf(buf, sizeof buf, "%s loop (auto: rays visit %.1f nodes, %s %.0f)", if_if ? "if-if" : "while-while",
                  sah_visits_per_ray, if_if ? "at least" : "under", kIfIfMinVisits);
  else
    std::snprintf(buf, sizeof buf, "%s loop (PENUMBRA_CUDA_LOOP)", if_if ? "if-if" : "while-while");
  f.reason = buf;
  if (if_if) f.closest = f.shadow = kBvhIfIf;
  if (flat && flat_setting == "auto") {
    f.closest |= kBvhFlat;
    f.shadow |= kBvhFlat;
    f.reason += ", flat scene";
  } else {
    f.reason += flat ? ", general form (PENUMBRA_CUDA_FLAT=0)" : ", general form";
  }
  // The FMA box test keeps o / d's products live beside o: where the flat form frees registers, shadow rays gain
  // by it; closest hits (more state) and the general form spill for it and lose.
  const bool fma_shadow = box == "auto" ? (f.shadow & kBvhFlat) != 0 : box == "fma";
  if (fma_shadow) f.shadow |= kBvhFmaBox;
  if (box == "fma") f.closest |= kBvhFmaBox;
  f.reason += box == "slab"  ? ", subtract-multiply box test (PENUMBRA_CUDA_BOX)"
              : box == "fma" ? ", FMA box test (PENUMBRA_CUDA_BOX)"
              : fma_shadow   ? ", FMA box test for shadow rays"
                             : ", subtract-multiply box test";
  return f;
}

}  // namespace pn
