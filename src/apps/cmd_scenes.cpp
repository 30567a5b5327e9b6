#include <cstdio>
#include <string>

#include "apps/commands.h"
#include "scene/scene.h"

namespace pn {

Command add_scenes_command(CLI::App& app) {
  auto* sub = app.add_subcommand("scenes", "List the built-in scenes, or print one as an editable scene file");
  auto dump = std::make_shared<std::string>();
  sub->add_option("--dump", *dump, "Print the named built-in scene as JSON (save it, edit it, render it)");
  return {sub, [dump]() {
    if (!dump->empty()) {
      const BuiltinScene* b = find_builtin(*dump);
      if (!b) throw SceneError(*dump + ": not a built-in scene (see `penumbra scenes`)");
      std::printf("%s\n", b->make().dump(2).c_str());
      return 0;
    }
    for (const auto& s : builtin_scenes()) std::printf("%-16s %s\n", s.name, s.description);
    return 0;
  }};
}

}  // namespace pn
