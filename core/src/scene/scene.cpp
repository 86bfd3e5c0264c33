#include "frichb/core/scene/scene.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/scene/scene_variables.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/plugin/sdk.hpp"
#include "scene/mistuning.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using sdk::Param;

namespace {

// ---- The core's own schemas (single source of truth for validation and the reference) ----

const std::vector<frichb_param_spec>& top_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("name", "short name of the scene, used in plots").defaults_to_text(""),
      Param::text("description", "free text").defaults_to_text(""),
      Param::text_list("plugin_paths",
                       "extra folders searched for plugins, relative to the scene file")
          .optional(),
  };
  return s;
}
const std::vector<frichb_param_spec>& structure_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("provider", "structure-provider plugin name (`frichb plugins` lists them)"),
      Param::path("mesh",
                  "model map (mesh.yaml: FE node numbers, coordinates, nodal frames, contact "
                  "faces) of an FE structure, relative to the scene's folder; optional")
          .defaults_to_text(""),
  };
  return s;
}
const frichb_param_spec* excitation_fields() {
  static const frichb_param_spec f[] = {
      Param::text("dof", "name of the excited DOF or node (a key of structure.dofs)"),
      Param::real("amplitude", "N", "force amplitude").at_least(0),
      Param::integer("harmonic", "temporal harmonic number n of the force")
          .defaults_to(1)
          .at_least(0),
      Param::real("phase_deg", "deg", "phase: force = amplitude cos(n w t + phase)").defaults_to(0),
      Param::real_list("direction", "",
                       "direction over the node's components (nodes with more than one DOF)")
          .optional(),
      Param::text("axis",
                  "for a node of the model map: the force along a global axis (ux, uy, uz) or "
                  "radial / circumferential about the global z axis at the node (ur, ut), turned "
                  "into the node's frame; instead of direction")
          .optional()
          .choices("ux|uy|uz|ur|ut"),
      Param::real_list("global_direction", "",
                       "for a node of the model map: the direction [x, y, z] in global "
                       "coordinates, turned into the node's frame; instead of direction")
          .optional(),
  };
  return f;
}
constexpr std::size_t kExcitationFieldCount = 7;
const std::vector<frichb_param_spec>& excitation_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::records("excitation", "harmonic point forces", excitation_fields(),
                     kExcitationFieldCount)
          .optional()};
  return s;
}
const std::vector<frichb_param_spec>& contact_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("name", "name of the contact, used in outputs"),
      Param::text("law", "contact-law plugin name (`frichb plugins` lists them)"),
  };
  return s;
}
const std::vector<frichb_param_spec>& side_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("node", "node name (a key of structure.dofs) or 'ground'"),
      Param::integer("sector", "sector offset from the reference sector (cyclic scenes)")
          .defaults_to(0)
          .at_least(-1)
          .at_most(1),
  };
  return s;
}
const std::vector<frichb_param_spec>& cyclic_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::integer("sectors", "number of sectors nb of the tuned disk").at_least(2),
      Param::integer("engine_order", "engine order m of the travelling-wave excitation")
          .at_least(0),
  };
  return s;
}
const std::vector<frichb_param_spec>& frame_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real_list("tangent1", "", "first tangential direction over the node's components")
          .optional(),
      Param::real_list("tangent2", "", "second tangential direction (2D tangential laws)")
          .optional(),
      Param::real_list("normal", "",
                       "normal direction, pointing so that u_n > 0 closes the contact")
          .optional(),
  };
  return s;
}
const std::vector<frichb_param_spec>& harmonic_balance_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real_list("harmonics", "", "kept temporal harmonics, e.g. [0, 1, 3, 5]")
          .at_least(0)
          .optional(),
      Param::integer("max_harmonic", "keep harmonics 0..max_harmonic (instead of `harmonics`)")
          .defaults_to(-1)
          .at_least(-1),
      Param::integer("samples_per_period", "time samples N of the AFT; N >= 2 max_harmonic + 1")
          .defaults_to(128)
          .at_least(2)
          .at_most(1 << 19),
      Param::text("jacobian", "contact Jacobian: quasi-analytical, or finite differences")
          .defaults_to_text("analytic")
          .choices("analytic|finite_difference"),
      Param::integer("trace_oversampling",
                     "trace the contacts on this many times samples_per_period (a return "
                     "mapping converges to first order in the time step)")
          .defaults_to(1)
          .at_least(1)
          .at_most(64),
      Param::integer("max_trace_passes", "bound on passes over the period for periodicity")
          .defaults_to(200)
          .at_least(1),
      Param::boolean("periodic_state_newton",
                     "between passes, Newton steps onto the periodic state of contacts whose law "
                     "gives tangents (false: plain passes only)")
          .defaults_to(1),
      Param::boolean("trace_along_motion",
                     "laws that can (coupled_3d) follow the harmonic series between samples, "
                     "with their events inside the steps and the force harmonics corrected at "
                     "the kinks (false: their sample-only step)")
          .defaults_to(1),
  };
  return s;
}
const std::vector<frichb_param_spec>& continuation_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::integer("target_newton_iterations", "N* of the step adaptation ds*sqrt(N*/N)")
          .defaults_to(4)
          .at_least(1)
          .at_most(20),
      Param::integer("max_newton_iterations", "corrector iterations before a step is retried")
          .defaults_to(25)
          .at_least(2),
      Param::integer("max_points", "bound on converged points").defaults_to(2000).at_least(2),
      Param::real("tolerance", "", "Newton tolerance on the scaled residual and update")
          .defaults_to(1e-9)
          .greater_than(0)
          .at_most(1e-2),
      Param::boolean("turning_point_control",
                     "step back and refine tenfold where the frequency tangent changes sign")
          .defaults_to(1),
      Param::real("steep_branch_alpha", "", "steep-branch cap threshold alpha (thesis: 20-40)")
          .defaults_to(30)
          .greater_than(1),
      Param::real("max_wall_seconds", "s", "wall-clock bound of the continuation")
          .defaults_to(600)
          .greater_than(0),
      Param::real("displacement_scale", "m",
                  "scale of the displacement unknowns in the arclength; 0 = automatic")
          .defaults_to(0)
          .at_least(0),
      Param::integer("reuse_factorisation_from",
                     "unknowns from which a step is first corrected by chord iterations on the "
                     "last point's factorisation (full Newton when they stall); 0 = never")
          .defaults_to(1000)
          .at_least(0),
      Param::text("linear_solver",
                  "solver of the Newton and tangent systems: dense_lu factorises every matrix; "
                  "gmres iterates on it, preconditioned by the factorisation of an earlier one "
                  "(refactorised when the iterations grow); matrix_free iterates on the "
                  "harmonic-balance Jacobian applied as receptances times contact tangents, "
                  "never formed, preconditioned by its harmonic-decoupled approximation; auto: "
                  "matrix_free from matrix_free_from unknowns on")
          .defaults_to_text("auto")
          .choices("auto|dense_lu|gmres|matrix_free"),
      Param::integer("matrix_free_from",
                     "unknowns from which linear_solver auto picks matrix_free (measured faster "
                     "from about 500 unknowns: docs/performance.md)")
          .defaults_to(500)
          .at_least(0),
      Param::integer("gmres_from",
                     "unknowns from which linear_solver auto picks gmres for a model that cannot "
                     "apply its Jacobian as an operator")
          .defaults_to(5000)
          .at_least(0),
  };
  return s;
}
const std::vector<frichb_param_spec>& frequency_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real("from", "Hz or rad/s", "start of the sweep").at_least(0),
      Param::real("to", "Hz or rad/s", "end of the sweep").at_least(0),
      Param::text("unit", "unit of from/to, steps and friction_loops_at")
          .defaults_to_text("Hz")
          .choices("Hz|rad/s"),
  };
  return s;
}
const std::vector<frichb_param_spec>& step_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real("initial", "Hz or rad/s", "first arclength step").defaults_to(1).greater_than(0),
      Param::real("min", "Hz or rad/s", "smallest step before giving up")
          .defaults_to(1e-4)
          .greater_than(0),
      Param::real("max", "Hz or rad/s", "largest step").defaults_to(10).greater_than(0),
  };
  return s;
}
const std::vector<frichb_param_spec>& output_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text_list("response", "nodes whose amplitude goes to response.csv").optional(),
      Param::real_list("friction_loops_at", "Hz or rad/s",
                       "frequencies where friction loops are written")
          .greater_than(0)
          .optional(),
      Param::real_list("contact_states_at", "Hz or rad/s",
                       "frequencies where each contact's shares of the period stuck, slipping "
                       "and open are written (contact_states/; a patch's pairs also as a plot "
                       "of the face)")
          .greater_than(0)
          .optional(),
      Param::boolean("plots", "write gnuplot scripts and PNG plots").defaults_to(1),
      Param::text("amplitude_axis",
                  "amplitude axis of the response and study plots: log, linear, or auto (log "
                  "where the plotted amplitudes span more than a decade)")
          .defaults_to_text("auto")
          .choices("auto|linear|log"),
      Param::boolean("contact_forces",
                     "write contact_harmonics.csv: every contact's force and relative "
                     "displacement harmonics at every point of the curve")
          .defaults_to(0),
      Param::boolean("stability",
                     "Floquet multipliers of every point: response.csv gains the columns "
                     "stable, largest_multiplier and unstable_multipliers, summary.json the "
                     "bifurcations and the highest stable point; for a cyclic scene, perturbed in "
                     "every nodal diameter, also the nodal diameter of each point's largest "
                     "multiplier (the whole disk: at most 2000 unknowns)")
          .defaults_to(0),
  };
  return s;
}

sdk::Params view(const std::vector<frichb_param_spec>& schema, const ParamValues& values) {
  return sdk::Params(schema.data(), schema.size(), values.data());
}

std::vector<double> unit_vector(const std::vector<double>& v, const YAML::Node& node,
                                const std::string& path, const YamlContext& ctx,
                                std::size_t components) {
  if (v.size() != components)
    ctx.fail(node, path,
             "has " + std::to_string(v.size()) + " entries but the node has " +
                 std::to_string(components) + " components");
  // Scaled by the largest entry: the squares neither overflow (1e200 gave the zero vector)
  // nor underflow (1e-200 was "the zero vector").
  double scale = 0;
  for (double x : v) scale = std::max(scale, std::abs(x));
  if (scale == 0) ctx.fail(node, path, "is the zero vector");
  double sum = 0;
  for (double x : v) sum += (x / scale) * (x / scale);
  const double norm = scale * std::sqrt(sum);
  std::vector<double> out;
  out.reserve(v.size());
  for (double x : v) out.push_back(x / norm);
  return out;
}

}  // namespace

const NodeSpec* StructureSpec::find(const std::string& name) const {
  for (const auto& n : nodes)
    if (n.name == name) return &n;
  return nullptr;
}

namespace {

// The node `name` names: a key of structure.dofs, else (with a model map) an FE node number or
// a one-node set of the map, added to the structure's nodes on first use. Null when none, with
// the reason in `why`.
const NodeSpec* resolve_node(StructureSpec& s, const std::string& name, std::string& why) {
  if (const NodeSpec* n = s.find(name)) return n;
  why = "'" + name + "' is not a key of structure.dofs";
  if (!s.mesh) return nullptr;
  why += ", an FE node of the model map or one of its one-node sets";
  std::int64_t number = fe_node_number(name);
  if (const auto it = s.mesh->node_sets.find(name);
      number < 0 && it != s.mesh->node_sets.end() && it->second.size() == 1)
    number = it->second.front();
  const MeshNode* m = number > 0 ? s.mesh->find(number) : nullptr;
  if (!m) return nullptr;
  NodeSpec node;
  node.name = name;
  node.from_mesh = true;
  node.fe_node = number;
  node.line = m->line;
  node.defined_in = s.mesh->nodes_file.string();
  for (int k = 0; k < 3; ++k) {
    if (m->rows[static_cast<std::size_t>(k)] < 0) {
      why = "FE node " + std::to_string(number) + " has its component " + std::to_string(k + 1) +
            " outside the matrices (fixed)";
      return nullptr;
    }
    node.dofs.push_back(static_cast<std::size_t>(m->rows[static_cast<std::size_t>(k)]));
  }
  s.nodes.push_back(std::move(node));
  return &s.nodes.back();
}

}  // namespace

std::string unit_name(FrequencyUnit unit) {
  return unit == FrequencyUnit::kHz ? "Hz" : "rad/s";
}

double ContinuationSpec::to_rad_per_s() const {
  return unit == FrequencyUnit::kHz ? 2.0 * std::numbers::pi : 1.0;
}

namespace {

// Names that become file names, CSV columns and --set paths (contacts.NAME.params.kt,
// structure.dofs.NAME): letters, digits, '_' and '-', not starting with '-'. A '.' would split
// the path (and names a patch's node pairs, NAME.NODE).
bool is_plain_name(const std::string& name) {
  return !name.empty() && name[0] != '-' && std::all_of(name.begin(), name.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-';
  });
}

// Why a plain contact name cannot be a contact's, or "": digits alone address a list entry by
// its index in --set paths (contacts.0 is the first contact, whatever its name).
std::string contact_name_problem(const std::string& name) {
  if (!is_plain_name(name))
    return "'" + name + "': use letters, digits, '_' and '-' (it names files and --set paths)";
  if (name.find_first_not_of("0123456789") == std::string::npos)
    return "'" + name + "': a name of digits alone is read as a list index by --set (contacts." +
           name + " is the contact at index " + name + ", counted from 0): put a letter in it";
  return "";
}

// A contact's name is part of the names of its result files
// (loops/<contact>_<frequency><unit>_<crossing>_harmonics.csv; a patch's
// contact_states/<frequency><unit>_<crossing>_<patch>_face.png), and the file system takes
// names of at most NAME_MAX bytes: 64 of them are left for what is added to the contact's name.
constexpr std::size_t kMaxFileNamePart = NAME_MAX - 64;

// Why `name` is too long to be part of a file name, or "" when it fits.
std::string too_long_for_a_file_name(const std::string& name) {
  if (name.size() <= kMaxFileNamePart) return {};
  return "'" + name.substr(0, 32) + "...' (" + std::to_string(name.size()) +
         " characters) is too long: it is part of the names of result files, which the file "
         "system limits to " +
         std::to_string(NAME_MAX) + " bytes; use at most " + std::to_string(kMaxFileNamePart) +
         " characters";
}

std::string child_path(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

// The end of the quoted scalar that opens at `text[open]` (a ' or "), or npos when the file
// ends first. yaml-cpp reads an unclosed quote as a string running to the end of the file.
std::size_t closing_quote(const std::string& text, std::size_t open) {
  const char quote = text[open];
  for (std::size_t i = open + 1; i < text.size(); ++i) {
    if (quote == '"' && text[i] == '\\') {
      ++i;
    } else if (text[i] == quote) {
      if (quote == '\'' && i + 1 < text.size() && text[i + 1] == '\'') {
        ++i;  // '' is a quote inside a single-quoted scalar
        continue;
      }
      return i;
    }
  }
  return std::string::npos;
}

// What yaml-cpp accepts silently and a scene must not hold: a key twice in one map (yaml-cpp
// keeps both and a lookup finds the first) and a quoted scalar that is never closed.
void check_strict(const YAML::Node& node, const std::string& path, const std::string& text,
                  const std::string& file, int depth, std::size_t& visited) {
  // Aliases can make a cycle or a tree that doubles at every level: bounded.
  constexpr int kMaxDepth = 64;
  constexpr std::size_t kMaxNodes = 1000000;
  if (depth > kMaxDepth || ++visited > kMaxNodes)
    throw SceneError(file, node.Mark().line + 1, node.Mark().column + 1, path,
                     "the YAML nests deeper than " + std::to_string(kMaxDepth) +
                         " levels or holds more than a million nodes (aliases that refer to "
                         "themselves or to each other?)");
  if (node.IsScalar()) {
    const YAML::Mark m = node.Mark();
    if (node.Tag() == "!" && m.pos >= 0 && static_cast<std::size_t>(m.pos) < text.size()) {
      const auto open = static_cast<std::size_t>(m.pos);
      if ((text[open] == '"' || text[open] == '\'') &&
          closing_quote(text, open) == std::string::npos)
        throw SceneError(file, m.line + 1, m.column + 1, path,
                         std::string("malformed YAML: the quote ") + text[open] +
                             " opened here is never closed");
    }
    return;
  }
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      check_strict(node[i], path + "[" + std::to_string(i) + "]", text, file, depth + 1, visited);
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, YAML::Mark> seen;
  for (const auto& kv : node) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    if (kv.first.IsScalar()) {
      const auto [at, inserted] = seen.emplace(key, kv.first.Mark());
      if (!inserted)
        throw SceneError(
            file, kv.first.Mark().line + 1, kv.first.Mark().column + 1, child_path(path, key),
            "duplicate key '" + key + "': given on line " + std::to_string(at->second.line + 1) +
                " and again on line " + std::to_string(kv.first.Mark().line + 1) +
                " (keep one; YAML readers differ on which one wins)");
    }
    check_strict(kv.first, path, text, file, depth + 1, visited);
    check_strict(kv.second, child_path(path, key), text, file, depth + 1, visited);
  }
}

}  // namespace

// The largest scene file read (a scene holds keys, not meshes or tables).
constexpr std::uintmax_t kMaxSceneBytes = 16U << 20U;

YAML::Node load_scene_yaml(const fs::path& file) {
  std::string text;
  {
    if (const std::string problem = regular_file_problem(file); !problem.empty())
      throw SceneError(file.string(), 0, 0, "",
                       problem == "is a folder" ? "is a folder, not a scene file"
                                                : "cannot open the scene file: it " + problem);
    std::error_code ec;
    if (fs::file_size(file, ec) > kMaxSceneBytes)
      throw SceneError(file.string(), 0, 0, "",
                       "is larger than " + std::to_string(kMaxSceneBytes >> 20U) +
                           " MiB: not a scene (meshes and tables belong in files it names)");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw SceneError(file.string(), 0, 0, "", "cannot open the scene file");
    std::ostringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  }
  return parse_scene_yaml(text, file);
}

YAML::Node parse_scene_yaml(const std::string& text, const fs::path& file) {
  if (text.size() > kMaxSceneBytes)
    throw SceneError(file.string(), 0, 0, "",
                     "is larger than " + std::to_string(kMaxSceneBytes >> 20U) +
                         " MiB: not a scene (meshes and tables belong in files it names)");
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(text);
  } catch (const YAML::Exception& e) {
    // A ${name} in a flow map or list: YAML reads its braces as its own, before any
    // substitution (which works on the scalars YAML has read).
    std::string hint;
    std::istringstream lines(text);
    std::string line;
    for (int k = 0; k <= e.mark.line && std::getline(lines, line);) ++k;
    if (e.mark.line >= 0 && line.find("${") != std::string::npos)
      hint = " (a ${name} inside a flow map or list, {...} or [...], must be quoted: \"${name}\")";
    throw SceneError(file.string(), e.mark.line + 1, e.mark.column + 1, "",
                     "malformed YAML: " + e.msg + hint);
  }
  if (documents.size() > 1) {
    // Where the second document starts: its root's mark, or the second `---` line.
    int line = documents[1].Mark().line;
    if (line < 0) {
      std::istringstream lines(text);
      std::string l;
      int number = 0, separators = 0;
      const bool explicit_start = text.starts_with("---");
      while (std::getline(lines, l)) {
        if (l.starts_with("---") && ++separators == (explicit_start ? 2 : 1)) {
          line = number;
          break;
        }
        ++number;
      }
    }
    throw SceneError(file.string(), line + 1, 1, "",
                     "a second YAML document (after `---`): a scene file holds one document; "
                     "put each scene in a file of its own");
  }
  YAML::Node root = documents.empty() ? YAML::Node() : documents.front();
  std::size_t visited = 0;
  check_strict(root, "", text, file.string(), 0, visited);
  return root;
}

namespace {

// The scene document of `file`, or of `text` when given, with `overrides` applied.
YAML::Node scene_document(const fs::path& file, const std::string* text,
                          const std::vector<SceneOverride>& overrides) {
  YAML::Node document = text ? parse_scene_yaml(*text, file) : load_scene_yaml(file);
  for (const auto& o : overrides) {
    try {
      set_scene_override(document, o);
    } catch (const std::invalid_argument& e) {
      throw SceneError(file.string(), 0, 0, "--set " + o.path, e.what());
    }
  }
  return document;
}

}  // namespace

YAML::Node load_scene_document(const fs::path& file, const std::vector<SceneOverride>& overrides) {
  return scene_document(file, nullptr, overrides);
}

YAML::Node reread_scene_document(const Scene& base) {
  return scene_document(base.file, base.text.get(), base.overrides);
}

Scene load_scene_variant(const YAML::Node& document, const Scene& base) {
  Scene scene = load_scene(document, base.file);
  scene.overrides = base.overrides;
  scene.text = base.text;
  scene.allow_scene_plugins = base.allow_scene_plugins;
  return scene;
}

Scene load_scene(const fs::path& file, const std::vector<SceneOverride>& overrides) {
  Scene scene = load_scene(load_scene_document(file, overrides), file);
  scene.overrides = overrides;
  return scene;
}

namespace {

// The readers below take the scene's root as a non-const handle: a const operator[] on a
// missing key gives an invalid node that throws. Each reads one section into `scene`, checks
// it and records its values, defaults filled in, in scene.core_values.

// The top-level keys (name, description, plugin_paths); every other top-level key must be one
// of the sections.
void read_top_level(Scene& scene, const YAML::Node& root, const YamlContext& ctx) {
  if (!root.IsMap()) ctx.fail(root, "", "a scene is a YAML map of sections");
  const std::vector<std::string> sections = {
      "structure", "excitation", "contacts", "harmonic_balance", "continuation",
      "output",    "cyclic",     "study",    "variables",        "mistuning"};
  const auto top = validate_params(root, top_schema(), "", ctx, sections);
  const auto topv = view(top_schema(), top);
  scene.name = topv.text("name");
  scene.description = topv.text("description");
  scene.plugin_paths =
      resolve_plugin_paths(topv.texts("plugin_paths"), root, scene.file, "scene", ctx);
  scene.core_values = top.to_json(top_schema());
}

// cyclic: {sectors, engine_order}, when given.
void read_cyclic(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node cy = root["cyclic"];
  if (!cy) return;
  const auto cv = validate_params(cy, cyclic_schema(), "cyclic", ctx);
  const auto c = view(cyclic_schema(), cv);
  scene.cyclic.sectors = static_cast<int>(c.integer("sectors"));
  scene.cyclic.engine_order = static_cast<int>(c.integer("engine_order"));
  scene.core_values["cyclic"] = cv.to_json(cyclic_schema());
}

// One entry `name: index` or `name: [i, j, k]` of the DOF map, checked against the nodes
// already read. `dofs_ctx` names the file the map is in.
NodeSpec read_dof_node(const StructureSpec& structure, const YAML::Node& key,
                       const YAML::Node& value, const YamlContext& dofs_ctx) {
  NodeSpec node;
  if (!key.IsScalar()) dofs_ctx.fail(key, "structure.dofs", "a DOF name must be plain text");
  node.name = key.Scalar();
  node.defined_in = dofs_ctx.file;
  node.definition = value;
  const std::string path = "structure.dofs." + node.name;
  if (node.name == "ground") dofs_ctx.fail(key, path, "'ground' is reserved");
  if (!is_plain_name(node.name))
    dofs_ctx.fail(key, path,
                  "'" + node.name +
                      "': use letters, digits, '_' and '-' (it names columns of "
                      "response.csv and --set paths)");
  if (structure.find(node.name))
    dofs_ctx.fail(key, path, "DOF name '" + node.name + "' is used twice");
  if (structure.mesh && fe_node_number(node.name) > 0)
    dofs_ctx.fail(key, path,
                  "with a model map (structure.mesh) numbers name FE nodes: give this DOF group "
                  "a name that is not a number");
  auto read_index = [&](const YAML::Node& n) {
    double x = -1;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, x) || x < 0 || x != std::floor(x) ||
        x > std::numeric_limits<int>::max())
      dofs_ctx.fail(n, path, "expected a DOF index (integer >= 0) or a list of them");
    node.dofs.push_back(static_cast<std::size_t>(x));
  };
  if (value.IsSequence()) {
    if (value.size() == 0 || value.size() > 3) dofs_ctx.fail(value, path, "a node has 1 to 3 DOFs");
    for (const auto& n : value) read_index(n);
  } else {
    read_index(value);
  }
  return node;
}

// structure.dofs: the map itself or the path of a YAML file holding it (relative to the
// scene's folder), e.g. the DOF names a model pipeline writes next to its matrices.
void read_dof_map(Scene& scene, YAML::Node s, const YamlContext& ctx) {
  YAML::Node dofs = s["dofs"];
  YamlContext dofs_ctx = ctx;
  if (dofs && dofs.IsScalar()) {
    fs::path map_file(dofs.Scalar());
    if (!map_file.is_absolute()) map_file = scene.file.parent_path() / map_file;
    std::error_code ec;
    if (!fs::is_regular_file(map_file, ec))
      ctx.fail(dofs, "structure.dofs",
               "DOF map file '" + map_file.string() +
                   "' not found (a relative path is taken from the scene file's folder)");
    dofs = load_scene_yaml(map_file);
    dofs_ctx = YamlContext{map_file.string()};
  }
  if (!dofs || !dofs.IsMap() || dofs.size() == 0)
    dofs_ctx.fail(dofs ? dofs : s, "structure.dofs",
                  "expected a map naming DOFs, e.g. {blade: 0, damper: [3, 4, 5]}, or the path "
                  "of a YAML file holding one");
  for (const auto& kv : dofs)
    scene.structure.nodes.push_back(read_dof_node(scene.structure, kv.first, kv.second, dofs_ctx));
}

// structure: the provider, its still unvalidated params, and the DOF map.
void read_structure_section(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node s = root["structure"];
  if (!s) ctx.fail(root, "structure", "missing required section");
  const auto sv = validate_params(s, structure_schema(), "structure", ctx,
                                  std::vector<std::string>{"params", "dofs"});
  const auto v = view(structure_schema(), sv);
  scene.structure.provider = v.text("provider");
  scene.structure.params = s["params"];
  if (!v.text("mesh").empty()) {
    const fs::path mesh_file(v.text("mesh"));  // resolved against the scene's folder
    std::error_code ec;
    if (!fs::is_regular_file(mesh_file, ec))
      ctx.fail(s["mesh"], "structure.mesh",
               "model map '" + mesh_file.string() +
                   "' not found (a relative path is taken from the scene file's folder)");
    scene.structure.mesh = std::make_shared<const FeMesh>(load_fe_mesh(mesh_file));
  }
  if (s["dofs"] || !scene.structure.mesh) read_dof_map(scene, s, ctx);
  scene.core_values["structure"] = sv.to_json(structure_schema());
}

// harmonic_balance: the kept harmonics (listed, or 0..max_harmonic) and the AFT's sampling.
void read_harmonic_balance(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node hbn = root["harmonic_balance"];
  const auto hb = validate_params(hbn, harmonic_balance_schema(), "harmonic_balance", ctx);
  const auto hbv = view(harmonic_balance_schema(), hb);
  const auto listed = hbv.reals("harmonics");
  const long long max_h = hbv.integer("max_harmonic");
  if (listed.empty() == (max_h < 0))
    ctx.fail(hbn ? hbn : root, "harmonic_balance",
             "give exactly one of `harmonics: [...]` or `max_harmonic: H`");
  auto& H = scene.harmonic_balance;
  std::set<double> seen;
  for (std::size_t i = 0; i < listed.size(); ++i) {
    const double x = listed[i];
    if (x != std::floor(x) || !seen.insert(x).second)
      ctx.fail(hbn["harmonics"][i], "harmonic_balance.harmonics[" + std::to_string(i) + "]",
               "harmonics are distinct integers >= 0");
  }
  H.samples_per_period = static_cast<int>(hbv.integer("samples_per_period"));
  // Checked before the harmonics are listed as int: a huge max_harmonic or harmonic is refused
  // here (samples_per_period is bounded by its schema), not converted or enumerated.
  const double max_kept =
      max_h >= 0 ? static_cast<double>(max_h) : *std::max_element(listed.begin(), listed.end());
  if (const auto why = sampling_violation(H.samples_per_period, max_kept); !why.empty())
    ctx.fail(hbn["samples_per_period"] ? hbn["samples_per_period"] : hbn,
             "harmonic_balance.samples_per_period", why);
  if (max_h >= 0) {
    for (int n = 0; n <= max_h; ++n) H.harmonics.push_back(n);
  } else {
    for (double x : listed) H.harmonics.push_back(static_cast<int>(x));
  }
  H.analytic_jacobian = hbv.text("jacobian") == "analytic";
  H.max_trace_passes = static_cast<int>(hbv.integer("max_trace_passes"));
  H.periodic_state_newton = hbv.boolean("periodic_state_newton");
  H.trace_along_motion = hbv.boolean("trace_along_motion");
  H.trace_oversampling = static_cast<int>(hbv.integer("trace_oversampling"));
  scene.core_values["harmonic_balance"] = hb.to_json(harmonic_balance_schema());
}

// The global unit vector an excitation's `axis` or `global_direction` names at `node` (global
// Cartesian components), or throws at `entry`.
std::array<double, 3> global_force_direction(const MeshNode& node, const sdk::Params& r,
                                             YAML::Node entry, const std::string& path,
                                             const YamlContext& ctx) {
  const std::string axis = r.present("axis") ? r.text("axis") : std::string();
  if (axis.empty()) {
    const auto v = r.reals("global_direction");
    if (v.size() != 3)
      ctx.fail(entry["global_direction"], path + ".global_direction",
               "give three components [x, y, z]");
    const auto u = unit_vector(v, entry["global_direction"], path + ".global_direction", ctx, 3);
    return {u[0], u[1], u[2]};
  }
  if (axis == "ux") return {1, 0, 0};
  if (axis == "uy") return {0, 1, 0};
  if (axis == "uz") return {0, 0, 1};
  const double x = node.position[0], y = node.position[1], radius = std::hypot(x, y);
  if (!(radius > 0))
    ctx.fail(entry["axis"], path + ".axis",
             "FE node " + std::to_string(node.number) +
                 " lies on the z axis: it has no radial or circumferential direction");
  if (axis == "ur") return {x / radius, y / radius, 0};
  return {-y / radius, x / radius, 0};
}

// An excitation's direction over its node's components: `direction` as written (a one-DOF
// node defaults to [1]), or a global `axis` / `global_direction` turned into the frame of a
// node of the model map.
std::vector<double> excitation_direction(const StructureSpec& structure, const NodeSpec& node,
                                         const sdk::Params& r, YAML::Node entry,
                                         const std::string& path, const YamlContext& ctx) {
  auto dir = r.reals("direction");
  if (r.present("axis") || r.present("global_direction")) {
    const char* key = r.present("axis") ? "axis" : "global_direction";
    if (!dir.empty() || (r.present("axis") && r.present("global_direction")))
      ctx.fail(entry[key], path + "." + key,
               "give one of direction (the node's components), axis or global_direction");
    const MeshNode* m =
        node.from_mesh && structure.mesh ? structure.mesh->find(node.fe_node) : nullptr;
    if (!m)
      ctx.fail(entry[key], path + "." + key,
               "'" + node.name +
                   "' is not a node of the model map (structure.mesh): a global direction needs "
                   "its coordinates and nodal frame; give direction over its components");
    const auto v = FeMesh::to_nodal(*m, global_force_direction(*m, r, entry, path, ctx));
    return {v[0], v[1], v[2]};
  }
  if (dir.empty() && node.dofs.size() == 1) dir.push_back(1.0);
  if (dir.empty())
    ctx.fail(entry, path + ".direction",
             "node '" + node.name +
                 "' has several DOFs: give a direction (or, for a node of "
                 "the model map, a global axis or global_direction)");
  return unit_vector(dir, entry["direction"] ? entry["direction"] : entry, path + ".direction", ctx,
                     node.dofs.size());
}

// excitation: the harmonic point forces, on nodes of the structure and kept harmonics (read
// after structure and harmonic_balance).
void read_excitation(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node exn = root["excitation"];
  YAML::Node wrapped;
  wrapped["excitation"] = exn;
  const auto ex = validate_params(exn ? wrapped : YAML::Node(), excitation_schema(), "", ctx);
  const auto exv = view(excitation_schema(), ex);
  const auto& kept = scene.harmonic_balance.harmonics;
  for (std::size_t i = 0; i < exv.record_count("excitation"); ++i) {
    const auto r = exv.record("excitation", i);
    const std::string path = "excitation[" + std::to_string(i) + "]";
    ExcitationSpec e;
    e.node = r.text("dof");
    std::string why;
    const NodeSpec* node = resolve_node(scene.structure, e.node, why);
    if (!node) ctx.fail(exn[i]["dof"], path + ".dof", why);
    e.direction = excitation_direction(scene.structure, *node, r, exn[i], path, ctx);
    e.amplitude = r.real("amplitude");
    e.harmonic = static_cast<int>(r.integer("harmonic"));
    e.phase = r.real("phase_deg") * std::numbers::pi / 180.0;
    if (std::find(kept.begin(), kept.end(), e.harmonic) == kept.end())
      ctx.fail(exn[i], path + ".harmonic",
               "harmonic " + std::to_string(e.harmonic) +
                   " is not among harmonic_balance's kept harmonics");
    scene.excitation.push_back(std::move(e));
  }
  scene.core_values["excitation"] = ex.to_json(excitation_schema())["excitation"];
}

// A contact's `between: [side A, side B]` into contact.side_a/b and sector_a/b; returns the
// sides as JSON ({node, sector} each).
nlohmann::json read_contact_sides(const Scene& scene, YAML::Node c, const std::string& path,
                                  const YamlContext& ctx, ContactSpec& contact) {
  YAML::Node bn = c["between"];
  if (!bn || !bn.IsSequence() || bn.size() != 2)
    ctx.fail(bn ? bn : c, path + ".between",
             "expected [side A, side B]: node names, 'ground', or {node: name, sector: +1}");
  std::string sides[2];
  int sectors[2] = {0, 0};
  nlohmann::json between_json = nlohmann::json::array();
  for (int k = 0; k < 2; ++k) {
    const std::string side_path = path + ".between[" + std::to_string(k) + "]";
    YAML::Node sn = bn[k];
    if (sn.IsScalar()) {
      sides[k] = sn.Scalar();
    } else {
      const auto side_values = validate_params(sn, side_schema(), side_path, ctx);
      const auto side = view(side_schema(), side_values);
      sides[k] = side.text("node");
      sectors[k] = static_cast<int>(side.integer("sector"));
      if (sectors[k] != 0 && scene.cyclic.sectors < 2)
        ctx.fail(sn["sector"], side_path + ".sector",
                 "a neighbouring sector needs a `cyclic: {sectors, engine_order}` section");
    }
    between_json.push_back({{"node", sides[k]}, {"sector", sectors[k]}});
  }
  contact.side_a = sides[0];
  contact.side_b = sides[1];
  contact.sector_a = sectors[0];
  contact.sector_b = sectors[1];
  if (sides[0] == sides[1] && sectors[0] == sectors[1])
    ctx.fail(bn, path + ".between", "both sides are the same node of the same sector");
  return between_json;
}

// The DOF count of the contact's nodes (the sides that are not ground, which must agree).
std::size_t contact_components(Scene& scene, YAML::Node c, const std::string& path,
                               const YamlContext& ctx, const ContactSpec& contact) {
  YAML::Node bn = c["between"];
  const std::string* sides[2] = {&contact.side_a, &contact.side_b};
  std::size_t components = 0;
  for (int k = 0; k < 2; ++k) {
    const std::string& side = *sides[k];
    if (side == "ground") continue;
    std::string why;
    const NodeSpec* node = resolve_node(scene.structure, side, why);
    if (!node)
      ctx.fail(bn[k], path + ".between[" + std::to_string(k) + "]", why + " (nor 'ground')");
    if (components && node->dofs.size() != components)
      ctx.fail(bn, path + ".between", "the two sides have different DOF counts");
    components = node->dofs.size();
  }
  if (components == 0)
    ctx.fail(bn, path + ".between", "a contact needs at least one side that is not ground");
  return components;
}

// One entry of `contacts`; its values, defaults filled in, are appended to `contacts_json`.
ContactSpec read_contact(Scene& scene, YAML::Node c, const std::string& path,
                         const YamlContext& ctx, std::set<std::string>& contact_names,
                         nlohmann::json& contacts_json) {
  const auto cv = validate_params(c, contact_schema(), path, ctx,
                                  std::vector<std::string>{"between", "frame", "params"});
  const auto v = view(contact_schema(), cv);
  ContactSpec contact;
  contact.name = v.text("name");
  contact.law = v.text("law");
  if (const std::string why = contact_name_problem(contact.name); !why.empty())
    ctx.fail(c["name"], path + ".name", why);
  if (const std::string why = too_long_for_a_file_name(contact.name); !why.empty())
    ctx.fail(c["name"], path + ".name", why);
  if (!contact_names.insert(contact.name).second)
    ctx.fail(c["name"], path + ".name", "contact name '" + contact.name + "' is used twice");
  const nlohmann::json between_json = read_contact_sides(scene, c, path, ctx, contact);
  const std::size_t components = contact_components(scene, c, path, ctx, contact);
  YAML::Node fn = c["frame"];
  const auto fv = validate_params(fn, frame_schema(), path + ".frame", ctx);
  const auto f = view(frame_schema(), fv);
  auto vec = [&](const char* key) {
    const auto raw = f.reals(key);
    if (raw.empty()) return std::vector<double>{};
    return unit_vector(raw, fn[key], path + ".frame." + key, ctx, components);
  };
  contact.tangent1 = vec("tangent1");
  contact.tangent2 = vec("tangent2");
  contact.normal = vec("normal");
  if (contact.tangent1.empty() && components == 1) contact.tangent1 = {1.0};
  contact.params = c["params"];
  nlohmann::json cj = cv.to_json(contact_schema());
  cj["between"] = between_json;
  cj["frame"] = fv.to_json(frame_schema());
  contacts_json.push_back(cj);
  return contact;
}

// A patch as summary.json records it: its faces, settings and every pair.
nlohmann::json patch_json(const ContactPatch& patch) {
  nlohmann::json faces = nlohmann::json::array();
  faces.push_back({{"face", patch.face_a}, {"sector", patch.sector_a}});
  if (patch.face_b.empty())
    faces.push_back("ground");
  else
    faces.push_back({{"face", patch.face_b}, {"sector", patch.sector_b}});
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& p : patch.pairs) {
    nlohmann::json pj = {{"node_a", p.node_a},
                         {"node_b", p.node_b},
                         {"area_m2", p.area},
                         {"share", p.share},
                         {"in_plane_distance_m", p.in_plane_distance},
                         {"normal_distance_m", p.normal_distance}};
    for (const auto& [key, value] : p.overrides) pj[key] = value;
    pairs.push_back(pj);
  }
  return {{"faces", faces},
          {"tolerance", patch.tolerance},
          {"values", patch.per_area ? "per_area" : "total"},
          {"face_a_area_m2", patch.area_a},
          {"face_b_area_m2", patch.area_b},
          {"pair_count", patch.pairs.size()},
          {"pairs", pairs}};
}

// A patch entry (contact_patch.hpp): one contact per node pair, named `<name>.<node A>`.
void read_patch_contacts(Scene& scene, YAML::Node c, const std::string& path,
                         const YamlContext& ctx, std::set<std::string>& contact_names,
                         nlohmann::json& contacts_json) {
  if (c["between"])
    ctx.fail(c["between"], path + ".between", "a contact has either `between` or `patch`");
  if (!scene.structure.mesh)
    ctx.fail(c["patch"], path + ".patch",
             "a patch pairs the faces of a model map: give structure.mesh");
  const auto cv = validate_params(c, contact_schema(), path, ctx,
                                  std::vector<std::string>{"frame", "params", "patch"});
  const auto v = view(contact_schema(), cv);
  const std::string name = v.text("name");
  if (const std::string why = contact_name_problem(name); !why.empty())
    ctx.fail(c["name"], path + ".name", why);
  if (const std::string why = too_long_for_a_file_name(name); !why.empty())
    ctx.fail(c["name"], path + ".name", why);
  if (!contact_names.insert(name).second)
    ctx.fail(c["name"], path + ".name", "contact name '" + name + "' is used twice");
  auto patch = std::make_shared<const ContactPatch>(read_contact_patch(
      c, path, ctx, *scene.structure.mesh, scene.cyclic.enabled() ? scene.cyclic.sectors : 1));
  for (const auto& pair : patch->pairs) {
    ContactSpec contact;
    contact.name = name + "." + std::to_string(pair.node_a);
    if (const std::string why = too_long_for_a_file_name(contact.name); !why.empty())
      ctx.fail(c["name"], path + ".name", "the name of its node pair " + why);
    if (!contact_names.insert(contact.name).second)
      ctx.fail(c["name"], path + ".name", "contact name '" + contact.name + "' is used twice");
    contact.law = v.text("law");
    contact.side_a = std::to_string(pair.node_a);
    contact.side_b = pair.node_b ? std::to_string(pair.node_b) : "ground";
    contact.sector_a = patch->sector_a;
    contact.sector_b = pair.node_b ? patch->sector_b : 0;
    std::string why;
    for (const auto& side : {contact.side_a, contact.side_b})
      if (side != "ground" && !resolve_node(scene.structure, side, why))
        ctx.fail(c["patch"], path + ".patch", why);
    contact.tangent1.assign(pair.tangent1.begin(), pair.tangent1.end());
    contact.tangent2.assign(pair.tangent2.begin(), pair.tangent2.end());
    contact.normal.assign(pair.normal.begin(), pair.normal.end());
    contact.params = c["params"];
    contact.entry = contacts_json.size();
    contact.param_scale = pair.share;
    contact.param_overrides = pair.overrides;
    contact.patch = patch;
    scene.contacts.push_back(std::move(contact));
  }
  nlohmann::json cj = cv.to_json(contact_schema());
  cj["patch"] = patch_json(*patch);
  contacts_json.push_back(cj);
}

// contacts: a list of contacts between nodes of the structure (read after structure and
// cyclic), with distinct names; their law params are left to bind_plugins().
void read_contacts(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node cn = root["contacts"];
  if (cn && !cn.IsNull() && !cn.IsSequence())
    ctx.fail(cn, "contacts", "expected a list of contacts");
  std::set<std::string> contact_names;
  nlohmann::json contacts_json = nlohmann::json::array();
  for (std::size_t i = 0; cn && cn.IsSequence() && i < cn.size(); ++i) {
    const std::string path = "contacts[" + std::to_string(i) + "]";
    if (cn[i].IsMap() && cn[i]["patch"]) {
      read_patch_contacts(scene, cn[i], path, ctx, contact_names, contacts_json);
      continue;
    }
    ContactSpec contact = read_contact(scene, cn[i], path, ctx, contact_names, contacts_json);
    contact.entry = i;
    scene.contacts.push_back(std::move(contact));
  }
  scene.core_values["contacts"] = contacts_json;
}

// continuation: the frequency sweep, its steps and the corrector's settings.
void read_continuation(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node con = root["continuation"];
  if (!con) ctx.fail(root, "continuation", "missing required section (frequency sweep)");
  const auto cov = validate_params(con, continuation_schema(), "continuation", ctx,
                                   std::vector<std::string>{"frequency", "step"});
  const auto co = view(continuation_schema(), cov);
  if (!con["frequency"]) ctx.fail(con, "continuation.frequency", "missing {from, to, unit}");
  const auto fr =
      validate_params(con["frequency"], frequency_schema(), "continuation.frequency", ctx);
  const auto frv = view(frequency_schema(), fr);
  const auto st = validate_params(con["step"], step_schema(), "continuation.step", ctx);
  const auto stv = view(step_schema(), st);
  auto& C = scene.continuation;
  C.unit = frv.text("unit") == "Hz" ? FrequencyUnit::kHz : FrequencyUnit::kRadPerSecond;
  C.from = frv.real("from");
  C.to = frv.real("to");
  if (C.from == C.to) ctx.fail(con["frequency"], "continuation.frequency", "from equals to");
  if (std::min(C.from, C.to) <= 0)
    ctx.fail(con["frequency"], "continuation.frequency",
             "the sweep must stay above 0 (the static response is harmonic 0)");
  C.initial_step = stv.real("initial");
  C.min_step = stv.real("min");
  C.max_step = stv.real("max");
  if (!(C.min_step <= C.initial_step && C.initial_step <= C.max_step))
    ctx.fail(con["step"] ? con["step"] : con, "continuation.step",
             "steps must satisfy min <= initial <= max");
  C.target_newton_iterations = static_cast<int>(co.integer("target_newton_iterations"));
  C.max_newton_iterations = static_cast<int>(co.integer("max_newton_iterations"));
  C.max_points = static_cast<int>(co.integer("max_points"));
  C.tolerance = co.real("tolerance");
  C.turning_point_control = co.boolean("turning_point_control");
  C.steep_branch_alpha = co.real("steep_branch_alpha");
  C.max_wall_seconds = co.real("max_wall_seconds");
  C.displacement_scale = co.real("displacement_scale");
  C.reuse_factorisation_from = static_cast<int>(co.integer("reuse_factorisation_from"));
  C.linear_solver = co.text("linear_solver");
  C.gmres_from = static_cast<int>(co.integer("gmres_from"));
  C.matrix_free_from = static_cast<int>(co.integer("matrix_free_from"));
  nlohmann::json cj = cov.to_json(continuation_schema());
  cj["frequency"] = fr.to_json(frequency_schema());
  cj["step"] = st.to_json(step_schema());
  scene.core_values["continuation"] = cj;
}

// output: the response nodes (every node of the structure by default), the friction loops'
// frequencies and the plots switch.
void read_output(Scene& scene, YAML::Node root, const YamlContext& ctx) {
  YAML::Node on = root["output"];
  const auto ov = validate_params(on, output_schema(), "output", ctx);
  const auto o = view(output_schema(), ov);
  scene.output.response = o.texts("response");
  for (std::size_t i = 0; i < scene.output.response.size(); ++i) {
    std::string why;
    if (!resolve_node(scene.structure, scene.output.response[i], why))
      ctx.fail(on["response"][i], "output.response[" + std::to_string(i) + "]", why);
  }
  // By default the nodes of structure.dofs, else (a scene on a model map alone) the excited ones.
  if (scene.output.response.empty())
    for (const auto& n : scene.structure.nodes)
      if (!n.from_mesh) scene.output.response.push_back(n.name);
  if (scene.output.response.empty())
    for (const auto& e : scene.excitation)
      if (std::find(scene.output.response.begin(), scene.output.response.end(), e.node) ==
          scene.output.response.end())
        scene.output.response.push_back(e.node);
  scene.output.friction_loops_at = o.reals("friction_loops_at");
  scene.output.contact_states_at = o.reals("contact_states_at");
  scene.output.plots = o.boolean("plots");
  const std::string axis = o.text("amplitude_axis");
  scene.output.amplitude_axis = axis == "log"      ? AmplitudeAxis::log
                                : axis == "linear" ? AmplitudeAxis::linear
                                                   : AmplitudeAxis::automatic;
  scene.output.contact_forces = o.boolean("contact_forces");
  scene.output.stability = o.boolean("stability");
  // The stability of a cyclic scene copies the contacts' traces into every sector, delayed by
  // s m / nb of the period: a whole number of the traces' samples (model/stability.hpp).
  if (const auto& hb = scene.harmonic_balance; scene.output.stability && scene.cyclic.enabled()) {
    const long long samples = static_cast<long long>(hb.samples_per_period) * hb.trace_oversampling;
    if (samples * scene.cyclic.engine_order % scene.cyclic.sectors != 0)
      ctx.fail(on["stability"], "output.stability",
               "the stability of a cyclic scene needs harmonic_balance.samples_per_period (" +
                   std::to_string(hb.samples_per_period) + ") times trace_oversampling (" +
                   std::to_string(hb.trace_oversampling) + ") times cyclic.engine_order (" +
                   std::to_string(scene.cyclic.engine_order) +
                   ") to be a multiple of cyclic.sectors (" + std::to_string(scene.cyclic.sectors) +
                   "): each sector's motion is the reference's delayed by a whole number of "
                   "samples");
  }
  scene.core_values["output"] = ov.to_json(output_schema());
}

}  // namespace

Scene load_scene(const YAML::Node& document, const fs::path& file) {
  Scene scene;
  scene.file = file;
  scene.root = document;
  const YamlContext ctx{file.string()};
  substitute_scene_variables(scene.root, ctx);
  // In this order: a section is checked against those read before it.
  read_top_level(scene, scene.root, ctx);
  read_cyclic(scene, scene.root, ctx);
  read_structure_section(scene, scene.root, ctx);
  read_harmonic_balance(scene, scene.root, ctx);
  read_excitation(scene, scene.root, ctx);
  read_contacts(scene, scene.root, ctx);
  read_continuation(scene, scene.root, ctx);
  read_output(scene, scene.root, ctx);
  read_mistuning(scene, scene.root, ctx);
  if (scene.mistuning) {
    YAML::Node tuned = YAML::Clone(scene.root);
    tuned.remove("mistuning");
    scene.mistuning->tuned = std::make_shared<Scene>(load_scene(tuned, file));
  }
  return scene;
}

namespace {

// A patch pair's params: the entry's params validated as written (errors located there), then
// its force-valued params times the pair's share and its per-pair values set, validated again.
// The entry's params as written go to `written` (for summary.json).
ParamValues patch_pair_values(const Scene& scene, const ContactSpec& c, const std::string& path,
                              const YamlContext& ctx, nlohmann::json& written) {
  const auto schema = c.plugin->schema();
  const ParamValues given = validate_params(c.params, schema, path + ".params", ctx);
  written = given.to_json(schema);
  YAML::Node scaled = c.params && c.params.IsMap() ? YAML::Clone(c.params) : YAML::Node();
  for (std::size_t k = 0; k < schema.size(); ++k) {
    const auto& spec = schema[k];
    if (spec.type != FRICHB_PARAM_REAL || !is_force_valued_unit(spec.unit)) continue;
    const frichb_param_value& value = given.data()[k];
    if (value.present || value.real != 0)
      scaled[spec.name] = format_scene_value(value.real * c.param_scale);
  }
  for (const auto& [name, value] : c.param_overrides) {
    const std::string& key = name;  // a structured binding cannot be captured (C++17 rules)
    const bool known = std::any_of(schema.begin(), schema.end(),
                                   [&](const frichb_param_spec& p) { return key == p.name; });
    if (!known)
      ctx.fail(YAML::Node(scene.root["contacts"][c.entry]["patch"]), path + ".patch",
               "law '" + c.law + "' has no parameter '" + key + "' to set pair by pair");
    scaled[key] = format_scene_value(value);
  }
  return validate_params(scaled, schema, path + ".params", ctx);
}

}  // namespace

void bind_plugins(Scene& scene, const Registry& registry) {
  YamlContext ctx{scene.file.string()};
  auto fail_plugin = [&](const YAML::Node& node, const std::string& path, const PluginError& e) {
    ctx.fail(node, path, e.what());
  };
  try {
    check_plugin_allowed(registry.file_of(scene.structure.provider), scene.plugin_paths,
                         scene.allow_scene_plugins);
    scene.structure.plugin = registry.load(scene.structure.provider, FRICHB_KIND_STRUCTURE);
  } catch (const PluginError& e) {
    fail_plugin(scene.root["structure"]["provider"], "structure.provider", e);
  }
  scene.structure.values = validate_params(scene.structure.params, scene.structure.plugin->schema(),
                                           "structure.params", ctx);
  for (auto& c : scene.contacts) {
    const std::string path = "contacts[" + std::to_string(c.entry) + "]";
    try {
      check_plugin_allowed(registry.file_of(c.law), scene.plugin_paths, scene.allow_scene_plugins);
      c.plugin = registry.load(c.law, FRICHB_KIND_CONTACT_LAW);
    } catch (const PluginError& e) {
      fail_plugin(scene.root["contacts"][c.entry]["law"], path + ".law", e);
    }
    if (c.patch)
      c.values =
          patch_pair_values(scene, c, path, ctx, scene.core_values["contacts"][c.entry]["params"]);
    else
      c.values = validate_params(c.params, c.plugin->schema(), path + ".params", ctx);
  }
  if (scene.mistuning && scene.mistuning->tuned) {
    Scene& tuned = *scene.mistuning->tuned;
    tuned.overrides = scene.overrides;
    tuned.allow_scene_plugins = scene.allow_scene_plugins;
    tuned.text = scene.text;
    bind_plugins(tuned, registry);
  }
}

BoundScene load_bound_scene(const SceneInput& input) {
  BoundScene bound;
  try {
    if (input.text) {
      auto text = std::make_shared<const std::string>(*input.text);
      bound.scene = load_scene(scene_document(input.file, text.get(), input.overrides), input.file);
      bound.scene.overrides = input.overrides;
      bound.scene.text = std::move(text);
    } else {
      bound.scene = load_scene(input.file, input.overrides);
    }
    bound.scene.allow_scene_plugins = input.allow_scene_plugins;
    bound.registry =
        std::make_unique<Registry>(Registry::default_search_path(bound.scene.plugin_paths));
    bind_plugins(bound.scene, *bound.registry);
  } catch (const SceneError&) {
    throw;
  } catch (const PluginError&) {
    throw;
  } catch (const std::exception& e) {
    // Anything else while reading input (yaml-cpp conversions, the file system) is still bad
    // input, not an internal failure.
    throw SceneError(input.file.string(), 0, 0, "", e.what());
  }
  return bound;
}

nlohmann::json scene_to_json(const Scene& scene) {
  nlohmann::json j = scene.core_values;
  if (scene.structure.plugin)
    j["structure"]["params"] = scene.structure.values.to_json(scene.structure.plugin->schema());
  nlohmann::json dofs = nlohmann::json::object();
  for (const auto& n : scene.structure.nodes) dofs[n.name] = n.dofs;
  j["structure"]["dofs"] = dofs;
  for (const auto& c : scene.contacts)  // a patch's params are in core_values, as written
    if (c.plugin && !c.patch)
      j["contacts"][c.entry]["params"] = c.values.to_json(c.plugin->schema());
  return j;
}

std::vector<CoreSection> core_schemas() {
  return {
      {"(top level)", top_schema(),
       "Sections: `structure`, `excitation`, `contacts`, `harmonic_balance`, `continuation` "
       "(required), `output`, `cyclic`, `mistuning`, `study`, `variables`. `variables`: a map "
       "of names to "
       "values (`variables: {pairs: 16}`); `${name}` in any text value of the scene is "
       "replaced by the value as written, e.g. `mass: models/blade_p${pairs}/sector_mass.mtx`, "
       "and a study can sweep `variables.pairs`."},
      {"structure", structure_schema(),
       "`params`: the provider's parameters (see Structure providers below). `dofs`: a map "
       "naming the DOFs the scene refers to (or the path, relative to the scene's folder, of a "
       "YAML file holding that map), `name: index` for a scalar DOF or "
       "`name: [i, j, k]` for a node of 2-3 DOFs (indices 0-based in the provider's numbering)."},
      {"excitation", excitation_schema(),
       "`excitation` is a top-level list; each entry is one harmonic force "
       "`amplitude * cos(harmonic * w t + phase)` along `direction`."},
      {"cyclic", cyclic_schema(),
       "Optional: a tuned disk of `sectors` identical sectors under an engine-order excitation. "
       "The structure provider then models one sector (harmonic indices h = mod(n m, nb)), "
       "and contacts may join a node of the reference sector to one of its neighbour."},
      {"mistuning", mistuning_schema(),
       "Optional, on a cyclic scene: a mistuned disk. Blade j's stiffness (the part the "
       "structure provider calls the blade, e.g. lumped_cyclic's `blade_dofs`) is scaled by "
       "1 + deviations[j]; `sigma` instead draws the deviations at random. The whole disk is "
       "then computed: each node `name` of the sector becomes `name@j` on blade j, each contact "
       "`c` one per blade (`c@j`), each excitation entry one per blade, delayed by j m / nb of a "
       "period. See docs/mistuning.md."},
      {"contacts[]", contact_schema(),
       "`between`: [side A, side B], each a node name, `ground`, or `{node: name, sector: +1}` "
       "(sector offset -1, 0 or +1 in cyclic scenes; the map form below). "
       "`params`: the law's parameters (see Contact laws below). `frame`: the local directions "
       "(below). The relative displacement is u = frame . (x_B - x_A), B the second side. The "
       "law's force f (spring-like: +kt u when stuck) enters the equations of motion as "
       "M x'' + C x' + K x + f_nl = f_ext with f_nl = +f on B and -f on A (thesis eq. 2.13): "
       "the contact pushes B back by -f."},
      {"contacts[].between[]", side_schema(), "The map form of a side."},
      {"contacts[].patch", contact_patch_schema(),
       "Instead of `between`: one contact per node pair of two faces of the model map "
       "(`structure.mesh`), named `<name>.<node A>`. `faces`: [face A, face B], each a face "
       "name or `{face: name, sector: +1}`; B may be `ground`. Each node of A pairs with the "
       "node of B nearest in A's face plane (B rotated by the sectors between them), one to "
       "one, within `tolerance`; a node without partner is refused with the distance it missed "
       "by. Each pair's normal is minus A's outward normal, tangent1 the projection of "
       "`frame.tangent1` (a global direction; default: the first of z, x, y not within 25 "
       "degrees of the normal), tangent2 = normal x tangent1, in node A's nodal frame. The "
       "law's force-valued params (units N, N/m, N/m^1.5, ...) are totals shared by node A's "
       "tributary area, or per m^2 (`values: per_area`). See docs/fe-models.md."},
      {"contacts[].patch.faces[]", contact_patch_side_schema(), "The map form of a face."},
      {"contacts[].frame", frame_schema(),
       "Each vector has one entry per DOF of the sides' nodes and is normalised. A 1-DOF node "
       "defaults to tangent1 = [1]. A law uses tangent2 when it is 2D tangential and normal "
       "when its normal load varies. A node of the model map has the components of its nodal "
       "frame (nodes.csv)."},
      {"harmonic_balance", harmonic_balance_schema(),
       "Give `harmonics` or `max_harmonic`. Every excited harmonic must be kept."},
      {"continuation", continuation_schema(), "Sub-maps `frequency` (required) and `step`."},
      {"continuation.frequency", frequency_schema(), ""},
      {"continuation.step", step_schema(),
       "Arclength steps in the frequency unit; displacements are scaled (see docs/theory.md)."},
      {"output", output_schema(), "`response` defaults to every node of `structure.dofs`."}};
}

std::vector<fs::path> resolve_plugin_paths(const std::vector<std::string>& listed, YAML::Node root,
                                           const fs::path& file, const std::string& kind,
                                           const YamlContext& ctx) {
  std::vector<fs::path> paths;
  for (std::size_t i = 0; i < listed.size(); ++i) {
    fs::path path(listed[i]);
    if (!path.is_absolute()) path = file.parent_path() / path;
    std::error_code missing;
    if (!fs::is_directory(path, missing))
      ctx.fail(root["plugin_paths"][i], "plugin_paths[" + std::to_string(i) + "]",
               "folder '" + path.string() + "' does not exist (a relative path is taken from the " +
                   kind + " file's folder)");
    paths.push_back(path);
  }
  return paths;
}

}  // namespace frichb::core
