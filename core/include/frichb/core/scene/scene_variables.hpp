// Scene variables: a top-level map `variables: {name: value, ...}` whose values replace
// `${name}` wherever it appears in a scene's text values, so that one scene can name a family of
// models (paths that differ by a mesh density, a case number, ...) and a study can sweep it
// (`path: variables.pairs`).
//
// Substitution is textual and one pass: `${name}` inside any scalar outside `variables` becomes
// the value exactly as written (a swept number in its shortest form: 16, 2.5e-05); the result
// is the scalar's new text, read afterwards like any value written by hand. It is never parsed
// as YAML, nor handed to a shell or an interpreter. A `${` always starts a reference; keys
// cannot hold one.
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>

#include "frichb/core/plugin_host/schema.hpp"

namespace frichb::core {

// Checks `root["variables"]` (absent, or a map of plain names - a letter or `_`, then letters,
// digits or `_` - to scalars that hold no `${`) and replaces every `${name}` in the other
// scalars of `root`, in place (the nodes keep their file positions). Returns the variables.
// Throws SceneError naming the file, line and key path of a malformed `variables` map, an
// unknown name, an unterminated `${` or a key holding `${`.
std::map<std::string, std::string> substitute_scene_variables(YAML::Node root,
                                                              const YamlContext& context);

}  // namespace frichb::core
