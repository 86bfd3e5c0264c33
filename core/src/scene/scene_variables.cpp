#include "frichb/core/scene/scene_variables.hpp"

#include <cctype>
#include <string>

namespace frichb::core {

namespace {

bool is_variable_name(const std::string& name) {
  if (name.empty()) return false;
  const auto first = static_cast<unsigned char>(name.front());
  if (!(std::isalpha(first) || first == '_')) return false;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (!(std::isalnum(u) || u == '_')) return false;
  }
  return true;
}

std::string listing(const std::map<std::string, std::string>& variables) {
  if (variables.empty()) return "the scene has no `variables`";
  std::string names;
  for (const auto& [name, value] : variables) names += (names.empty() ? "" : ", ") + name;
  return "variables: " + names;
}

std::string child(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

// `text` with every ${name} replaced; throws (at `node`, `path`) on an unknown name or an
// unterminated reference.
std::string substituted(const std::string& text, const std::map<std::string, std::string>& vars,
                        const YAML::Node& node, const std::string& path,
                        const YamlContext& context) {
  std::string out;
  std::size_t from = 0;
  for (;;) {
    const std::size_t open = text.find("${", from);
    if (open == std::string::npos) break;
    const std::size_t close = text.find('}', open + 2);
    if (close == std::string::npos)
      context.fail(node, path, "'" + text + "': a `${` without its closing `}`");
    const std::string name = text.substr(open + 2, close - open - 2);
    const auto it = vars.find(name);
    if (it == vars.end()) {
      std::string message = "'" + text + "': unknown variable '";
      message += name;
      message += "' (";
      message += listing(vars);
      message += ")";
      context.fail(node, path, message);
    }
    out.append(text, from, open - from);
    out += it->second;
    from = close + 1;
  }
  if (from == 0) return text;
  out.append(text, from, std::string::npos);
  return out;
}

void substitute(YAML::Node node,  // NOLINT(performance-unnecessary-value-param): a handle
                const std::string& path, const std::map<std::string, std::string>& vars,
                const YamlContext& context) {
  if (node.IsScalar()) {
    const std::string& text = node.Scalar();
    if (text.find("${") == std::string::npos) return;
    node = substituted(text, vars, node, path, context);
    return;
  }
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      substitute(node[i], path + "[" + std::to_string(i) + "]", vars, context);
    return;
  }
  if (node.IsMap()) {
    for (auto kv : node) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string("?");
      if (key.find("${") != std::string::npos)
        context.fail(kv.first, child(path, key),
                     "a key cannot hold a variable (`${` in a key): variables go in values");
      if (path.empty() && key == "variables") continue;
      substitute(kv.second, child(path, key), vars, context);
    }
  }
}

}  // namespace

std::map<std::string, std::string> substitute_scene_variables(YAML::Node root,
                                                              const YamlContext& context) {
  std::map<std::string, std::string> vars;
  if (!root.IsMap()) return vars;
  const YAML::Node section = root["variables"];
  if (!section) return vars;
  if (!section.IsMap())
    context.fail(section, "variables",
                 "a map of names to values, e.g. variables: {pairs: 16, case: shroud_a}");
  for (const auto& kv : section) {
    const std::string name = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    const std::string path = "variables." + name;
    if (!is_variable_name(name))
      context.fail(
          kv.first, "variables",
          "'" + name + "' is not a variable name (a letter or `_`, then letters, digits or `_`)");
    if (!kv.second.IsScalar())
      context.fail(kv.second, path, "a variable holds one value (a number or a word)");
    const std::string& value = kv.second.Scalar();
    if (value.find("${") != std::string::npos)
      context.fail(kv.second, path, "a variable's value cannot refer to a variable");
    vars[name] = value;
  }
  substitute(root, "", vars, context);
  return vars;
}

}  // namespace frichb::core
