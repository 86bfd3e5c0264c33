// Scene-key paths: addressing one scalar (or list) of a scene document, and the command
// line's --set overrides (scene.hpp).
#include "frichb/core/scene/scene.hpp"

#include <yaml-cpp/yaml.h>

#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "frichb/core/plugin_host/schema.hpp"

namespace frichb::core {
namespace {

// Joins text pieces into one string.
template <class... Parts>
std::string cat(const Parts&... parts) {
  std::string out;
  (out += ... += parts);
  return out;
}

// A list index of a path (digits only); one beyond unsigned long is an invalid path, not a
// std::out_of_range escaping the input checks.
std::size_t list_index(const std::string& digits, const std::string& path) {
  try {
    return std::stoul(digits);
  } catch (const std::out_of_range&) {
    throw std::invalid_argument(cat("'", path, "': ", digits, " is not a list index"));
  }
}

// One part of a path: a map key (or a contact's name) followed by list indices.
struct PathPart {
  std::string key;
  std::vector<std::size_t> indices;
};

std::vector<PathPart> parse_path(const std::string& path) {
  std::vector<PathPart> parts;
  std::size_t i = 0;
  while (i <= path.size()) {
    PathPart part;
    while (i < path.size() && path[i] != '.' && path[i] != '[') part.key += path[i++];
    while (i < path.size() && path[i] == '[') {
      const std::size_t close = path.find(']', i);
      if (close == std::string::npos)
        throw std::invalid_argument(cat("'", path, "': unclosed '['"));
      const std::string digits = path.substr(i + 1, close - i - 1);
      if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
        throw std::invalid_argument(cat("'", path, "': [", digits, "] is not a list index"));
      part.indices.push_back(list_index(digits, path));
      i = close + 1;
    }
    if (part.key.empty() && (parts.empty() || part.indices.empty()))
      throw std::invalid_argument(cat("'", path, "': empty key"));
    parts.push_back(std::move(part));
    if (i == path.size()) break;
    if (path[i] != '.') throw std::invalid_argument(cat("'", path, "': expected '.' or '['"));
    ++i;
    if (i == path.size()) throw std::invalid_argument(cat("'", path, "': ends with '.'"));
  }
  return parts;
}

std::vector<std::string> map_keys(const YAML::Node& map) {
  std::vector<std::string> keys;
  for (const auto& kv : map)
    if (kv.first.IsScalar()) keys.push_back(kv.first.Scalar());
  return keys;
}

// What a path may address: a number (study sweeps), a scalar (a --set scalar value), or a
// scalar or a list (a --set list value replaces either).
enum class Addressable { kNumber, kScalar, kScalarOrList };

// Finds the node at `path`, creating the last key of a map when absent. `create` false:
// only checks (and never inserts).
// `document` is a handle (yaml-cpp nodes share their data): edits go through it.
YAML::Node resolve(YAML::Node document,  // NOLINT(performance-unnecessary-value-param)
                   const std::string& path, bool create,
                   Addressable addressable = Addressable::kNumber) {
  const auto parts = parse_path(path);
  YAML::Node node = document;
  std::string walked;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const auto& part = parts[p];
    const bool last_part = p + 1 == parts.size();
    if (!part.key.empty()) {
      const std::string here = walked.empty() ? part.key : walked + "." + part.key;
      const bool numeric = part.key.find_first_not_of("0123456789") == std::string::npos;
      if (node.IsSequence() && numeric) {
        // A number addresses a list entry by index (excitation.0.amplitude).
        const std::size_t index = list_index(part.key, path);
        if (index >= node.size())
          throw std::invalid_argument(cat("'", walked, "' has ", std::to_string(node.size()),
                                          " entries, so '", here, "' does not exist"));
        node.reset(node[index]);
      } else if (node.IsSequence()) {
        // A list of named entries (contacts): the entry whose name is the key.
        YAML::Node found;
        bool matched = false;
        std::vector<std::string> names;
        for (std::size_t i = 0; i < node.size(); ++i) {
          YAML::Node entry = node[i];
          if (entry.IsMap() && entry["name"] && entry["name"].IsScalar()) {
            names.push_back(entry["name"].Scalar());
            if (names.back() == part.key) {
              found.reset(entry);
              matched = true;
            }
          }
        }
        if (!matched) {
          const std::string near = closest_match(part.key, names);
          throw std::invalid_argument("'" + walked + "' has no entry named '" + part.key + "'" +
                                      (near.empty() ? "" : " (did you mean '" + near + "'?)"));
        }
        node.reset(found);
      } else if (node.IsMap()) {
        YAML::Node child = node[part.key];
        if (!child) {
          if (!(last_part && part.indices.empty())) {
            const std::string near = closest_match(part.key, map_keys(node));
            throw std::invalid_argument("'" + here + "' is not in the scene" +
                                        (near.empty() ? "" : " (did you mean '" + near + "'?)"));
          }
          if (!create) return {};
        }
        node.reset(child);
      } else {
        throw std::invalid_argument(
            cat("'", walked, "' is not a map, so '", here, "' cannot be addressed"));
      }
      walked = here;
    }
    for (std::size_t index : part.indices) {
      const std::string here = walked + "[" + std::to_string(index) + "]";
      if (!node.IsSequence())
        throw std::invalid_argument(
            cat("'", walked, "' is not a list, so '", here, "' cannot be addressed"));
      if (index >= node.size())
        throw std::invalid_argument(cat("'", walked, "' has ", std::to_string(node.size()),
                                        " entries, so '", here, "' does not exist"));
      node.reset(node[index]);
      walked = here;
    }
  }
  if (!node || node.IsScalar() || (addressable == Addressable::kScalarOrList && node.IsSequence()))
    return node;
  if (addressable == Addressable::kNumber)
    throw std::invalid_argument("'" + path + "' is a " + (node.IsMap() ? "map" : "list") +
                                ", not a number");
  if (node.IsMap())
    throw std::invalid_argument("'" + path + "' is a map: set one of its keys, " + path +
                                ".KEY=VALUE");
  throw std::invalid_argument("'" + path + "' is a list: give a list, e.g. " + path + "=[1, 2]");
}

// A --set value: a scalar, or a flow list of scalars and lists ([1, 0, 0], [[1, 2], [3, 4]]).
bool scalars_and_lists(const YAML::Node& node) {
  if (node.IsScalar()) return true;
  if (!node.IsSequence()) return false;
  for (const auto& entry : node)
    if (!scalars_and_lists(entry)) return false;
  return true;
}

// A scalar as JSON: an integer or a finite number when the whole text reads as one, true or
// false, else the text.
nlohmann::json scalar_json(const std::string& text) {
  if (text == "true") return true;
  if (text == "false") return false;
  if (!text.empty() && text.find_first_not_of("+-0123456789") == std::string::npos) {
    try {
      std::size_t used = 0;
      const long long integer = std::stoll(text, &used);
      if (used == text.size()) return integer;
    } catch (const std::exception&) {
    }
  }
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  if (!text.empty() && end == text.c_str() + text.size() && std::isfinite(number)) return number;
  return text;
}

nlohmann::json value_json(const YAML::Node& node) {
  if (node.IsScalar()) return scalar_json(node.Scalar());
  nlohmann::json list = nlohmann::json::array();
  for (const auto& entry : node) list.push_back(value_json(entry));
  return list;
}

}  // namespace

std::string format_scene_value(double x) {
  if (x == std::floor(x) && std::abs(x) < 1e15) {
    std::ostringstream os;
    os << static_cast<long long>(x);
    return os.str();
  }
  // The shortest text that reads back as x (0.1, 2.5e-05), so that a swept value lands in a
  // scene variable's text as a user would write it.
  std::array<char, 64> buffer{};
  const auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), x);
  if (error != std::errc()) {
    std::ostringstream os;
    os << std::setprecision(17) << x;
    return os.str();
  }
  return std::string(buffer.data(), end);
}

void set_scene_value(YAML::Node document,  // NOLINT(performance-unnecessary-value-param)
                     const std::string& path, double value) {
  YAML::Node node = resolve(document, path, true);
  node = format_scene_value(value);
}

SceneOverride parse_scene_override(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw std::invalid_argument("expected PATH=VALUE");
  SceneOverride o{text.substr(0, eq), text.substr(eq + 1)};
  parse_path(o.path);  // a malformed path is a command-line error
  YAML::Node value;
  try {
    value = YAML::Load(o.value);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("'" + o.value + "' is not a YAML value: " + e.msg);
  }
  if (!value.IsDefined() || value.IsNull() || !scalars_and_lists(value))
    throw std::invalid_argument("'" + o.value + "' is not a value or a list of values");
  if (value.IsScalar()) {
    char* end = nullptr;
    const double number = std::strtod(o.value.c_str(), &end);
    if (end == o.value.c_str() + o.value.size() && !std::isfinite(number))
      throw std::invalid_argument("'" + o.value + "' is not a finite number");
  }
  return o;
}

nlohmann::json scene_override_json(const SceneOverride& o) {
  return value_json(YAML::Load(o.value));
}

void set_scene_override(YAML::Node document,  // NOLINT(performance-unnecessary-value-param)
                        const SceneOverride& o) {
  const YAML::Node value = YAML::Load(o.value);
  YAML::Node node = resolve(document, o.path, true,
                            value.IsSequence() ? Addressable::kScalarOrList : Addressable::kScalar);
  if (value.IsScalar())
    node = value.Scalar();  // keeps the scene's line and column for messages
  else
    node = value;
}

void check_scene_path(const YAML::Node& document, const std::string& path) {
  resolve(YAML::Clone(document), path, false);  // on a copy: resolving must not insert
}

}  // namespace frichb::core
