#include "apps/viewer/camera_path.h"

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

#include "apps/viewer/actions_table.h"
#include "scene/scene.h"

namespace pn::viewer {
namespace {

using ojson = nlohmann::ordered_json;  // keeps the keys of an entry in file order

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw SceneError(where + ": " + what); }

// The camera-path actions: those of the viewer's action table with a check.
const std::map<std::string, ActionCheck>& checks() {
  static const std::map<std::string, ActionCheck> table = [] {
    std::map<std::string, ActionCheck> t;
    for_each_action([&](const char* name, const ActionCheck& check, const auto&) {
      if (check) t.emplace(name, check);
    });
    return t;
  }();
  return table;
}

}  // namespace

const std::vector<std::string>& viewer_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k;
    for_each_key([&](const std::string& name, const auto&) { k.push_back(name); });
    return k;
  }();
  return keys;
}

bool is_viewer_key(const std::string& name) {
  return std::find(viewer_keys().begin(), viewer_keys().end(), name) != viewer_keys().end();
}

const std::vector<std::string>& camera_path_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k;
    for (const auto& kv : checks()) k.push_back(kv.first);
    return k;
  }();
  return keys;
}

std::vector<PathAction> parse_camera_path(const std::string& text, const std::string& source) {
  ojson doc = ojson::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) fail(source, "invalid JSON");
  if (!doc.is_array()) fail(source, "must be a JSON list of actions [{\"frame\": N, ...}, ...]");
  std::vector<PathAction> actions;
  for (size_t i = 0; i < doc.size(); ++i) {
    const ojson& entry = doc[i];
    std::string where = source + ": [" + std::to_string(i) + "]";
    if (!entry.is_object()) fail(where, "must be an object {\"frame\": N, \"<action>\": value}");
    if (!entry.contains("frame")) fail(where, "has no \"frame\"");
    const ojson& f = entry["frame"];
    if (!f.is_number_unsigned() && !(f.is_number_integer() && f.get<long long>() >= 0))
      fail(where + ".frame", "must be an integer >= 0 (got " + f.dump() + ")");
    if (entry.size() < 2) fail(where, "has no action besides \"frame\"");
    for (const auto& kv : entry.items()) {
      if (kv.key() == "frame") continue;
      auto it = checks().find(kv.key());
      if (it == checks().end()) {
        std::string names;
        for (const auto& k : camera_path_keys()) names += (names.empty() ? "" : ", ") + k;
        fail(where, "unknown action '" + kv.key() + "' (known: " + names + ")");
      }
      it->second(kv.value(), where + "." + kv.key());
      if (kv.key() == "screenshot" && f.get<uint64_t>() == 0)
        fail(where + ".screenshot", "needs a frame >= 1: there is no image before the first frame");
      actions.push_back({f.get<uint64_t>(), kv.key(), nlohmann::json::parse(kv.value().dump()), where + "." + kv.key()});
    }
  }
  std::stable_sort(actions.begin(), actions.end(),
                   [](const PathAction& a, const PathAction& b) { return a.frame < b.frame; });
  return actions;
}

std::vector<PathAction> load_camera_path(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open the camera path");
  std::stringstream buf;
  buf << in.rdbuf();
  return parse_camera_path(buf.str(), path);
}

}  // namespace pn::viewer
