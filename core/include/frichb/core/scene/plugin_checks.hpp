// The checks of a bound scene that need its plugins' instances: what the scene says against
// what its structure and its contact laws are. A model built from a scene that passes them
// (HarmonicBalanceModel) meets its own preconditions; every error names the scene file, the line
// and the key.
#pragma once

#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

// Throws SceneError, located at the key, when
//   - a DOF a structure node names does not exist in the structure (dof_count()),
//   - the structure's sector count differs from cyclic.sectors (or a sector model has no
//     cyclic section),
//   - a contact law refuses its params (its create() fails: the plugin's message, at the key it
//     names), or
//   - a contact lacks a frame direction (tangent1, tangent2, normal) its law uses.
// Creates (and destroys) one instance of each contact law. Reads the scene and the structure
// only; safe to call concurrently on distinct scenes.
void check_scene_against_plugins(const Scene& scene, const StructureModel& structure);

}  // namespace frichb::core
