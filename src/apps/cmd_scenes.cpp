#include <cstdio>
#include <string>

#include "apps/commands.h"
#include "scene/scene.h"

namespace pn {

Command add_scenes_command(CLI::App& app) {
  auto* sub = app.add_subcommand("scenes", "List the built-in scenes, or print one as an editable scene file");
  auto dump = std::make_shared<std::string>();
  sub->add_option("--dump", *dump, "Print the named built-in scene as JSON (save it, edit it, render it)")
      ->check(CLI::Validator(
          [](std::string& name) -> std::string {
            return find_builtin(name) ? "" : name + ": not a built-in scene (`penumbra scenes` lists them)";
          },
          ""));
  return {sub, [dump]() {
    if (!dump->empty()) {
      std::printf("%s\n", find_builtin(*dump)->make().dump(2).c_str());
      return 0;
    }
    for (const auto& s : builtin_scenes()) std::printf("%-16s %s\n", s.name, s.description);
    return 0;
  }};
}

}  // namespace pn
