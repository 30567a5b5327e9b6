// Fuzz target: scene files with --set overrides. The input is a scene's JSON
// text, optionally followed by a NUL byte and one "key=value" override a line.
// Files the scene names resolve in tests/data (its meshes, models, textures).
#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (pn::fuzz::escapes(data, size)) return 0;
  std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> overrides;
  if (auto nul = text.find('\0'); nul != std::string::npos) {
    std::string rest = text.substr(nul + 1);
    text.resize(nul);
    size_t start = 0;
    while (start <= rest.size() && overrides.size() < 16) {
      size_t end = rest.find('\n', start);
      if (end == std::string::npos) end = rest.size();
      if (end > start) overrides.push_back(rest.substr(start, end - start));
      start = end + 1;
    }
  }
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;
  try {
    for (const std::string& o : overrides) pn::apply_override(doc, o, "fuzz.json");
    pn::Scene s = pn::parse_scene(doc, "fuzz.json", PENUMBRA_FUZZ_DATA);
    // What every backend does next: the flat view, the camera, the integrator's settings.
    auto view = pn::make_host_view(s);
    (void)s.make_camera();
    (void)s.integrator();
    (void)s.features();
  } catch (const pn::SceneError&) {
  }
  return 0;
}
