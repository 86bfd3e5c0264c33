// Validation of YAML parameter maps against a plugin's (or the core's) parameter schema.
//
// The schema (frichb_param_spec, see <frichb/plugin/abi.h>) is the single source of truth:
// this file validates scene input against it, fills defaults, produces the plain values
// handed to a plugin's create(), and renders the schema as a table for `frichb describe`
// and the generated scene reference.
#pragma once

#include <yaml-cpp/yaml.h>

#include <deque>
#include <nlohmann/json.hpp>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "frichb/plugin/abi.h"

namespace frichb::core {

// An input error located in a YAML file. what() reads "file:line:column: key.path: message"
// (line and column 1-based; omitted when unknown), with the bytes a terminal would interpret
// (control characters, invalid UTF-8) written as \xNN (printable_text); message() is as given.
class SceneError : public std::runtime_error {
 public:
  SceneError(std::string file, int line, int column, std::string key_path, std::string message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }
  const std::string& key_path() const { return key_path_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_, key_path_, message_;
  int line_, column_;
};

// Where a YAML node came from, for error messages.
struct YamlContext {
  std::string file;
  [[noreturn]] void fail(const YAML::Node& node, const std::string& key_path,
                         const std::string& message) const;
};

// A plugin's refusal (its create() or a later call failed) located in the scene: at the key of
// `params` whose name the message quotes (the first schema name it contains as a word), else
// at `params` itself, else at `section`. `params_path` is the key path of `params`
// (e.g. "structure.params").
[[noreturn]] void fail_plugin_refusal(const YamlContext& context, const YAML::Node& section,
                                      const std::string& params_path,
                                      std::span<const frichb_param_spec> schema,
                                      const std::string& message);

// Owning storage of validated values, aligned index by index with the schema. The
// frichb_param_value array and everything it points to stay valid while this object lives
// (it is movable, not copyable: moving keeps every pointer valid).
class ParamValues {
 public:
  ParamValues() = default;
  ParamValues(ParamValues&&) = default;
  ParamValues& operator=(ParamValues&&) = default;
  ParamValues(const ParamValues&) = delete;
  ParamValues& operator=(const ParamValues&) = delete;

  const frichb_param_value* data() const { return values_.data(); }
  std::size_t size() const { return values_.size(); }
  // The values with defaults filled in, as JSON (for summary.json).
  nlohmann::json to_json(std::span<const frichb_param_spec> schema) const;

  // Building blocks used by validate_params(); exposed for hosts that build values in code.
  static ParamValues defaults(std::span<const frichb_param_spec> schema);

 private:
  friend class ParamBuilder;
  friend ParamValues validate_params(const YAML::Node&, std::span<const frichb_param_spec>,
                                     const std::string&, const struct YamlContext&,
                                     std::span<const std::string>);
  std::vector<frichb_param_value> values_;
  std::deque<std::vector<double>> real_storage_;
  std::deque<std::string> text_storage_;
  std::deque<std::vector<const char*>> text_pointer_storage_;
  std::deque<std::vector<frichb_param_value>> record_storage_;
};

// Validates the map `node` (may be undefined/null: then every value is defaulted) against
// `schema`. Unknown keys, wrong types, out-of-range or missing values throw SceneError
// naming file, line, column and `key_path`.key. Keys listed in `ignored_keys` are skipped
// (a caller validates them separately).
ParamValues validate_params(const YAML::Node& node, std::span<const frichb_param_spec> schema,
                            const std::string& key_path, const YamlContext& context,
                            std::span<const std::string> ignored_keys = {});

// Human-readable rule of a spec, e.g. "> 0", "[0, 1]", "2..2 entries", "one of a|b".
std::string describe_range(const frichb_param_spec& spec);
std::string describe_type(const frichb_param_spec& spec);
std::string describe_default(const frichb_param_spec& spec);
// A Markdown table of the schema (nested record fields as `name.field` rows).
std::string schema_markdown_table(std::span<const frichb_param_spec> schema);
// Closest candidate by edit distance, or "" when none is reasonably close.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace frichb::core
