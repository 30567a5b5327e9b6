// `penumbra view --camera-path FILE`: a scripted sequence of camera moves and
// control changes, for tests, demos and reproducible screenshots. The format is
// in docs/viewer.md: a JSON list of {"frame": N, "<action>": value, ...}.
//
// Everything is validated when the file is read, so a typo fails at once with
// one line naming the file and the entry, never 500 frames into a run.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pn::viewer {

struct PathAction {
  uint64_t frame = 0;     // applied after this many frames have been rendered
  std::string key;        // "orbit", "strategy", "screenshot", ...
  nlohmann::json value;   // validated for `key`
  std::string where;      // "path.json: [3].orbit", for messages
};

// The actions in the order they run: by frame, and within a frame in the
// order they appear in the file (entries, then keys within an entry).
std::vector<PathAction> load_camera_path(const std::string& path);
std::vector<PathAction> parse_camera_path(const std::string& text, const std::string& source);

// The action names the format knows (the viewer's actions with a check,
// actions_table.h), sorted, for documentation and messages.
const std::vector<std::string>& camera_path_keys();

// The viewer's keys by name (for_each_key, actions_table.h), one list for the
// window's key presses and the camera path's "key" action ({"frame": N, "key":
// "N"}): "1".."9" (a strategy; "shift+1".. its right side in split screen),
// "R", "F", "P", "N", "Tab" (docs/viewer.md says what each does).
const std::vector<std::string>& viewer_keys();
// Whether `name` is one of them, "shift+" prefixed where that means something.
bool is_viewer_key(const std::string& name);

}  // namespace pn::viewer
