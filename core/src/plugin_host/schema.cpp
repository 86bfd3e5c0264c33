#include "frichb/core/plugin_host/schema.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace {

std::string format_location(const std::string& file, int line, int column) {
  std::string out = file;
  if (line > 0) out += ":" + std::to_string(line) + ":" + std::to_string(column);
  return out;
}

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string join_key(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

// The largest magnitude of an INTEGER parameter: the range of int.
constexpr int kMaxInteger = std::numeric_limits<int>::max();

bool decode_real(const YAML::Node& node, double& out) {
  if (!node.IsScalar()) return false;
  return YAML::convert<double>::decode(node, out) && std::isfinite(out);
}

}  // namespace

SceneError::SceneError(std::string file, int line, int column, std::string key_path,
                       std::string message)
    : std::runtime_error(printable_text(format_location(file, line, column) + ": " +
                                        (key_path.empty() ? "" : key_path + ": ") + message)),
      file_(std::move(file)),
      key_path_(std::move(key_path)),
      message_(std::move(message)),
      line_(line),
      column_(column) {}

void YamlContext::fail(const YAML::Node& node, const std::string& key_path,
                       const std::string& message) const {
  int line = 0, column = 0;
  if (node.IsDefined() && node.Mark().line >= 0) {
    line = node.Mark().line + 1;
    column = node.Mark().column + 1;
  }
  throw SceneError(file, line, column, key_path, message);
}

void fail_plugin_refusal(const YamlContext& context, const YAML::Node& section,
                         const std::string& params_path, std::span<const frichb_param_spec> schema,
                         const std::string& message) {
  auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  const YAML::Node params = section.IsMap() ? section["params"] : YAML::Node();
  std::size_t best_at = std::string::npos;
  const char* best = nullptr;
  for (const auto& spec : schema) {
    const std::string name = spec.name;
    for (auto at = message.find(name); at != std::string::npos; at = message.find(name, at + 1)) {
      const bool starts = at == 0 || !word_char(message[at - 1]);
      const bool ends = at + name.size() >= message.size() || !word_char(message[at + name.size()]);
      if (starts && ends && params.IsMap() && params[name]) {
        if (at < best_at) {
          best_at = at;
          best = spec.name;
        }
        break;
      }
    }
  }
  if (best) context.fail(params[best], params_path + "." + best, message);
  if (params.IsDefined() && !params.IsNull()) context.fail(params, params_path, message);
  context.fail(section, params_path, message);
}

class ParamBuilder {
 public:
  ParamBuilder(ParamValues& store, const YamlContext& context) : store_(store), ctx_(context) {}

  frichb_param_value defaulted(const frichb_param_spec& spec) {
    frichb_param_value v{};
    v.present = 0;
    if (spec.type == FRICHB_PARAM_STRING || spec.type == FRICHB_PARAM_PATH) {
      v.text = store_text(spec.default_text ? spec.default_text : "");
    } else {
      v.real = spec.default_real;
    }
    return v;
  }

  frichb_param_value parse(const YAML::Node& node, const frichb_param_spec& spec,
                           const std::string& path) {
    frichb_param_value v{};
    v.present = 1;
    switch (spec.type) {
      case FRICHB_PARAM_REAL:
      case FRICHB_PARAM_INTEGER: {
        double x = 0.0;
        const bool integer = spec.type == FRICHB_PARAM_INTEGER;
        if (!decode_real(node, x) || (integer && x != std::floor(x)))
          ctx_.fail(node, path,
                    std::string("expected ") + (integer ? "an integer" : "a finite number") +
                        ", got " + describe_node(node));
        // Integers are read as int by the core and the plugins (sdk::Params::integer rounds
        // with llround, which has no defined result beyond long long): refuse what does not
        // fit rather than let 1e300 become garbage that has passed its range check.
        if (integer && std::abs(x) > kMaxInteger)
          ctx_.fail(node, path,
                    "value " + number_text(x) + " is out of the integer range [-" +
                        std::to_string(kMaxInteger) + ", " + std::to_string(kMaxInteger) + "]");
        check_range(node, spec, path, x);
        v.real = x;
        break;
      }
      case FRICHB_PARAM_BOOLEAN: {
        bool b = false;
        if (!node.IsScalar() || !YAML::convert<bool>::decode(node, b))
          ctx_.fail(node, path, "expected true or false, got " + describe_node(node));
        v.real = b ? 1.0 : 0.0;
        break;
      }
      case FRICHB_PARAM_STRING: {
        if (!node.IsScalar()) ctx_.fail(node, path, "expected text, got " + describe_node(node));
        const std::string& s = node.Scalar();
        if (spec.choices && !in_choices(s, spec.choices))
          ctx_.fail(node, path,
                    "'" + s + "' is not one of " + std::string(spec.choices) +
                        suggestion(s, split_choices(spec.choices)));
        v.text = store_text(s);
        break;
      }
      case FRICHB_PARAM_PATH: {
        if (!node.IsScalar())
          ctx_.fail(node, path, "expected a file path, got " + describe_node(node));
        std::filesystem::path file(node.Scalar());
        if (file.is_relative() && !ctx_.file.empty() && ctx_.file.front() != '<')
          file = std::filesystem::path(ctx_.file).parent_path() / file;
        v.text = store_text(file.lexically_normal().string());
        break;
      }
      case FRICHB_PARAM_REAL_LIST: {
        expect_list(node, spec, path);
        std::vector<double> xs;
        for (std::size_t i = 0; i < node.size(); ++i) {
          double x = 0.0;
          const std::string ip = path + "[" + std::to_string(i) + "]";
          if (!decode_real(node[i], x))
            ctx_.fail(node[i], ip, "expected a finite number, got " + describe_node(node[i]));
          check_range(node[i], spec, ip, x);
          xs.push_back(x);
        }
        store_.real_storage_.push_back(std::move(xs));
        v.reals = store_.real_storage_.back().data();
        v.n_reals = store_.real_storage_.back().size();
        break;
      }
      case FRICHB_PARAM_STRING_LIST: {
        expect_list(node, spec, path);
        std::vector<const char*> ptrs;
        for (std::size_t i = 0; i < node.size(); ++i) {
          if (!node[i].IsScalar())
            ctx_.fail(node[i], path + "[" + std::to_string(i) + "]",
                      "expected a scalar, got " + describe_node(node[i]));
          ptrs.push_back(store_text(node[i].Scalar()));
        }
        store_.text_pointer_storage_.push_back(std::move(ptrs));
        v.texts = store_.text_pointer_storage_.back().data();
        v.n_texts = store_.text_pointer_storage_.back().size();
        break;
      }
      case FRICHB_PARAM_RECORD_LIST: {
        expect_list(node, spec, path);
        std::vector<frichb_param_value> records;
        for (std::size_t i = 0; i < node.size(); ++i) {
          const std::string ip = path + "[" + std::to_string(i) + "]";
          auto fields = parse_map(node[i], {spec.fields, spec.n_fields}, ip, {});
          records.insert(records.end(), fields.begin(), fields.end());
        }
        store_.record_storage_.push_back(std::move(records));
        v.records = store_.record_storage_.back().data();
        v.n_records = node.size();
        break;
      }
      default:
        ctx_.fail(node, path, "schema has an unknown parameter type");
    }
    return v;
  }

  std::vector<frichb_param_value> parse_map(const YAML::Node& node,
                                            std::span<const frichb_param_spec> schema,
                                            const std::string& path,
                                            std::span<const std::string> ignored) {
    const bool is_map = node.IsDefined() && node.IsMap();
    if (node.IsDefined() && !node.IsNull() && !is_map)
      ctx_.fail(node, path, "expected a map of key: value, got " + describe_node(node));
    std::vector<std::string> names;
    for (const auto& s : schema) names.emplace_back(s.name);
    if (is_map) {
      for (const auto& kv : node) {
        if (!kv.first.IsScalar()) ctx_.fail(kv.first, path, "a key must be plain text");
        const std::string key = kv.first.Scalar();
        if (std::find(ignored.begin(), ignored.end(), key) != ignored.end()) continue;
        if (std::find(names.begin(), names.end(), key) == names.end()) {
          std::vector<std::string> all = names;
          all.insert(all.end(), ignored.begin(), ignored.end());
          ctx_.fail(kv.first, join_key(path, key),
                    "unknown key" + suggestion(key, all) + " (valid keys: " + join(all) + ")");
        }
      }
    }
    std::vector<frichb_param_value> out;
    for (const auto& spec : schema) {
      const YAML::Node child = is_map ? node[spec.name] : YAML::Node();
      const std::string key_path = join_key(path, spec.name);
      if (!child.IsDefined() || child.IsNull()) {
        if (spec.required) {
          std::string what = "missing required value (" + describe_type(spec);
          if (*spec.unit) what += std::string(", ") + spec.unit;
          ctx_.fail(node, key_path, what + ": " + spec.doc + ")");
        }
        out.push_back(defaulted(spec));
      } else {
        out.push_back(parse(child, spec, key_path));
      }
    }
    return out;
  }

 private:
  const char* store_text(const std::string& s) {
    store_.text_storage_.push_back(s);
    return store_.text_storage_.back().c_str();
  }
  static std::string describe_node(const YAML::Node& node) {
    if (node.IsMap()) return "a map";
    if (node.IsSequence()) return "a list";
    if (node.IsNull()) return "nothing";
    return "'" + node.Scalar() + "'";
  }
  static std::string join(const std::vector<std::string>& xs) {
    std::string out;
    for (const auto& x : xs) out += (out.empty() ? "" : ", ") + x;
    return out;
  }
  static std::vector<std::string> split_choices(const char* choices) {
    std::vector<std::string> out;
    std::string cur;
    for (const char* c = choices; *c; ++c) {
      if (*c == '|') {
        out.push_back(cur);
        cur.clear();
      } else {
        cur += *c;
      }
    }
    out.push_back(cur);
    return out;
  }
  static bool in_choices(const std::string& s, const char* choices) {
    const auto all = split_choices(choices);
    return std::find(all.begin(), all.end(), s) != all.end();
  }
  static std::string suggestion(const std::string& word, const std::vector<std::string>& all) {
    const std::string best = closest_match(word, all);
    return best.empty() ? "" : " (did you mean '" + best + "'?)";
  }
  void expect_list(const YAML::Node& node, const frichb_param_spec& spec, const std::string& path) {
    if (!node.IsSequence()) ctx_.fail(node, path, "expected a list, got " + describe_node(node));
    const std::size_t n = node.size();
    if ((spec.min_count && n < spec.min_count) || (spec.max_count && n > spec.max_count))
      ctx_.fail(node, path,
                "has " + std::to_string(n) + " entries, expected " + describe_range(spec));
  }
  void check_range(const YAML::Node& node, const frichb_param_spec& spec, const std::string& path,
                   double x) {
    const bool low_ok = spec.min_exclusive ? x > spec.min_value : x >= spec.min_value;
    const bool high_ok = spec.max_exclusive ? x < spec.max_value : x <= spec.max_value;
    if (low_ok && high_ok) return;
    std::string rule;
    const std::string leaf = path.substr(path.find_last_of('.') + 1);
    if (!low_ok)
      rule = leaf + (spec.min_exclusive ? " > " : " >= ") + number_text(spec.min_value);
    else
      rule = leaf + (spec.max_exclusive ? " < " : " <= ") + number_text(spec.max_value);
    ctx_.fail(node, path,
              "value " + number_text(x) + " violates " + rule + " (allowed " +
                  describe_range(spec) + (*spec.unit ? std::string(" ") + spec.unit : "") + ")");
  }

  ParamValues& store_;
  const YamlContext& ctx_;
};

ParamValues ParamValues::defaults(std::span<const frichb_param_spec> schema) {
  ParamValues values;
  YamlContext ctx{"<defaults>"};
  ParamBuilder builder(values, ctx);
  for (const auto& spec : schema) values.values_.push_back(builder.defaulted(spec));
  return values;
}

ParamValues validate_params(const YAML::Node& node, std::span<const frichb_param_spec> schema,
                            const std::string& key_path, const YamlContext& context,
                            std::span<const std::string> ignored_keys) {
  ParamValues values;
  ParamBuilder builder(values, context);
  values.values_ = builder.parse_map(node, schema, key_path, ignored_keys);
  return values;
}

namespace {
nlohmann::json value_json(const frichb_param_spec& spec, const frichb_param_value& v) {
  switch (spec.type) {
    case FRICHB_PARAM_REAL:
      return v.real;
    case FRICHB_PARAM_INTEGER:
      return static_cast<long long>(std::llround(v.real));
    case FRICHB_PARAM_BOOLEAN:
      return v.real != 0.0;
    case FRICHB_PARAM_STRING:
    case FRICHB_PARAM_PATH:
      return v.text ? std::string(v.text) : std::string();
    case FRICHB_PARAM_REAL_LIST:
      return std::vector<double>(v.reals, v.reals + v.n_reals);
    case FRICHB_PARAM_STRING_LIST: {
      nlohmann::json a = nlohmann::json::array();
      for (std::size_t i = 0; i < v.n_texts; ++i) a.push_back(v.texts[i]);
      return a;
    }
    case FRICHB_PARAM_RECORD_LIST: {
      nlohmann::json a = nlohmann::json::array();
      for (std::size_t r = 0; r < v.n_records; ++r) {
        nlohmann::json rec = nlohmann::json::object();
        for (std::size_t f = 0; f < spec.n_fields; ++f)
          rec[spec.fields[f].name] = value_json(spec.fields[f], v.records[r * spec.n_fields + f]);
        a.push_back(rec);
      }
      return a;
    }
    default:
      return nullptr;
  }
}
}  // namespace

nlohmann::json ParamValues::to_json(std::span<const frichb_param_spec> schema) const {
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < schema.size() && i < values_.size(); ++i)
    out[schema[i].name] = value_json(schema[i], values_[i]);
  return out;
}

std::string describe_type(const frichb_param_spec& spec) {
  switch (spec.type) {
    case FRICHB_PARAM_REAL:
      return "real";
    case FRICHB_PARAM_INTEGER:
      return "integer";
    case FRICHB_PARAM_BOOLEAN:
      return "boolean";
    case FRICHB_PARAM_STRING:
      return "text";
    case FRICHB_PARAM_PATH:
      return "file path";
    case FRICHB_PARAM_REAL_LIST:
      return "list of reals";
    case FRICHB_PARAM_STRING_LIST:
      return "list of scalars";
    case FRICHB_PARAM_RECORD_LIST:
      return "list of records";
    default:
      return "unknown";
  }
}

std::string describe_range(const frichb_param_spec& spec) {
  if (spec.type == FRICHB_PARAM_STRING) {
    if (!spec.choices) return "any";
    // Listed with commas: a '|' would split a Markdown table's cell.
    std::string list = spec.choices;
    for (std::size_t at = list.find('|'); at != std::string::npos; at = list.find('|', at))
      list.replace(at, 1, ", ");
    return "one of " + list;
  }
  std::string out;
  const bool has_lo = std::isfinite(spec.min_value), has_hi = std::isfinite(spec.max_value);
  if (spec.type == FRICHB_PARAM_REAL || spec.type == FRICHB_PARAM_INTEGER ||
      spec.type == FRICHB_PARAM_REAL_LIST) {
    if (has_lo && has_hi)
      out = std::string(spec.min_exclusive ? "(" : "[") + number_text(spec.min_value) + ", " +
            number_text(spec.max_value) + (spec.max_exclusive ? ")" : "]");
    else if (has_lo)
      out = std::string(spec.min_exclusive ? "> " : ">= ") + number_text(spec.min_value);
    else if (has_hi)
      out = std::string(spec.max_exclusive ? "< " : "<= ") + number_text(spec.max_value);
  }
  if (spec.min_count || spec.max_count) {
    std::string count = std::to_string(spec.min_count) + ".." +
                        (spec.max_count ? std::to_string(spec.max_count) : "") + " entries";
    out = out.empty() ? count : out + ", " + count;
  }
  return out.empty() ? "any" : out;
}

std::string describe_default(const frichb_param_spec& spec) {
  if (spec.required) return "required";
  switch (spec.type) {
    case FRICHB_PARAM_REAL:
    case FRICHB_PARAM_INTEGER:
      return number_text(spec.default_real);
    case FRICHB_PARAM_BOOLEAN:
      return spec.default_real != 0.0 ? "true" : "false";
    case FRICHB_PARAM_STRING:
      return spec.default_text ? std::string(spec.default_text) : "";
    default:
      return "empty";
  }
}

std::string schema_markdown_table(std::span<const frichb_param_spec> schema) {
  std::string out = "| key | type | unit | default | allowed | description |\n";
  out += "|---|---|---|---|---|---|\n";
  auto row = [&](const std::string& name, const frichb_param_spec& s) {
    out += "| `" + name + "` | " + describe_type(s) + " | " + (*s.unit ? s.unit : "-") + " | " +
           describe_default(s) + " | " + describe_range(s) + " | " + s.doc + " |\n";
  };
  for (const auto& s : schema) {
    row(s.name, s);
    for (std::size_t f = 0; f < s.n_fields; ++f)
      row(std::string(s.name) + "[]." + s.fields[f].name, s.fields[f]);
  }
  return out;
}

std::string closest_match(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const auto& c : candidates) {
    std::vector<std::size_t> prev(c.size() + 1), cur(c.size() + 1);
    for (std::size_t j = 0; j <= c.size(); ++j) prev[j] = j;
    for (std::size_t i = 1; i <= word.size(); ++i) {
      cur[0] = i;
      for (std::size_t j = 1; j <= c.size(); ++j) {
        const std::size_t sub = prev[j - 1] + (word[i - 1] == c[j - 1] ? 0 : 1);
        cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
      }
      std::swap(prev, cur);
    }
    if (prev[c.size()] < best_distance) {
      best_distance = prev[c.size()];
      best = c;
    }
  }
  // Close means at most a third of the word wrong (and at least one edit allowed).
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  return best_distance <= limit ? best : std::string();
}

}  // namespace frichb::core
