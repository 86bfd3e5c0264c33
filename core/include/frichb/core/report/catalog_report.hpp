// What `frichb plugins`, `describe` and `reference` print or write (commands/catalog.hpp).
#pragma once

#include <ostream>
#include <string>

#include "frichb/core/commands/catalog.hpp"

namespace frichb::core {

// The search path (each folder, "(missing)" when absent) and every plugin: name, kind,
// version, summary and file.
void print_plugins(const PluginsResult& result, std::ostream& out);
// A plugin's name, version, kind, summary, file, build tag and parameter table (Markdown), or
// the core sections' tables.
void print_description(const DescribeResult& result, std::ostream& out);
// The scene reference as Markdown (docs/scene-reference.md is this text).
std::string reference_markdown(const ReferenceResult& result);

}  // namespace frichb::core
