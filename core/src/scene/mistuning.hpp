// The scene's `mistuning` section (MistuningSpec in scene.hpp), read after every other
// section: it turns the tuned sector's scene into the whole mistuned disk's.
#pragma once

#include <vector>

#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

const std::vector<frichb_param_spec>& mistuning_schema();

// Reads `mistuning` (when present), sets scene.mistuning and expands the scene to the disk.
// Throws SceneError at the key: no cyclic section, a deviation count other than the sectors,
// both or neither of `deviations` and `sigma`, a pattern with a factor <= 0.
void read_mistuning(Scene& scene, YAML::Node root, const YamlContext& ctx);

}  // namespace frichb::core
