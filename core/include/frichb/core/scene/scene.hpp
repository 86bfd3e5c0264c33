// Scenes: the YAML a user writes (docs/scene-reference.md), parsed and validated.
//
// load_scene() checks the scene's own structure against the core's section schemas (every
// key known, every value typed and in range) and returns a Scene whose plugin `params` are
// still raw YAML. bind_plugins() then loads only the plugins the scene names and validates
// their params against each plugin's schema. Both steps run before any computation; every
// failure is a SceneError (file:line:column: key.path: message) or PluginError.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/scene/contact_patch.hpp"
#include "frichb/core/scene/fe_mesh.hpp"

namespace frichb::core {

enum class FrequencyUnit { kHz, kRadPerSecond };
// "Hz" or "rad/s", as messages, CSV headers and plot labels write the unit.
std::string unit_name(FrequencyUnit unit);

// A named group of structure DOFs (a scalar DOF, or a node's 2-3 translation DOFs).
struct NodeSpec {
  std::string name;
  std::vector<std::size_t> dofs;
  // Where the name was defined, for error messages: the file (the scene, or the DOF map file
  // `structure.dofs` points to) and the YAML value of its indices there.
  std::string defined_in;
  YAML::Node definition;
  // An FE node of the model map (`structure.mesh`) that the scene names by its number or by a
  // one-node set: its DOFs are the node's matrix rows, `line` its line in nodes.csv.
  bool from_mesh = false;
  std::int64_t fe_node = 0;  // its FE node number
  int line = 0;
};

struct ExcitationSpec {
  std::string node;
  std::vector<double> direction;  // unit vector over the node's components
  double amplitude = 0.0;         // N
  int harmonic = 1;               // temporal harmonic number
  double phase = 0.0;             // rad; force = amplitude cos(n w t + phase)
};

struct ContactSpec {
  std::string name;
  std::string law;
  std::string side_a, side_b;      // node names, or "ground"
  int sector_a = 0, sector_b = 0;  // sector offsets from the reference sector (cyclic scenes)
  // Unit frame vectors over the sides' node components; empty when not given.
  std::vector<double> tangent1, tangent2, normal;
  YAML::Node params;
  ParamValues values;  // set by bind_plugins()
  std::shared_ptr<const LoadedPlugin> plugin;
  // The index of the scene's `contacts` entry this contact comes from: a patch entry gives one
  // contact per node pair, named `<entry name>.<node A>`.
  std::size_t entry = 0;
  // A patch pair's share of the law's force-valued params (contact_patch.hpp), and the params
  // set pair by pair (gap, normal_load); bind_plugins() applies both to `params`.
  double param_scale = 1.0;
  std::map<std::string, double> param_overrides;
  std::shared_ptr<const ContactPatch> patch;  // the patch of a pair, else null
};

struct StructureSpec {
  std::string provider;
  YAML::Node params;
  std::vector<NodeSpec> nodes;  // in scene order
  // The model map (`structure.mesh`), or null: FE node numbers and its one-node sets then name
  // nodes too, and contact patches pair its faces.
  std::shared_ptr<const FeMesh> mesh;
  ParamValues values;  // set by bind_plugins()
  std::shared_ptr<const LoadedPlugin> plugin;
  const NodeSpec* find(const std::string& name) const;
};

struct HarmonicBalanceSpec {
  std::vector<int> harmonics;
  int samples_per_period = 128;
  bool analytic_jacobian = true;
  int max_trace_passes = 200;
  bool periodic_state_newton = true;  // TraceOptions::newton_on_periodic_state
  bool trace_along_motion = true;     // TraceOptions::along_motion
  int trace_oversampling = 1;         // contacts traced on trace_oversampling * samples_per_period
};

struct ContinuationSpec {
  FrequencyUnit unit = FrequencyUnit::kHz;
  double from = 0, to = 0;                                  // in `unit`
  double initial_step = 1, min_step = 1e-4, max_step = 10;  // arclength, in `unit`
  int target_newton_iterations = 4;
  int max_newton_iterations = 25;
  int max_points = 2000;
  double tolerance = 1e-9;
  bool turning_point_control = true;
  double steep_branch_alpha = 30;
  double max_wall_seconds = 600;
  double displacement_scale = 0;        // m; 0: automatic
  int reuse_factorisation_from = 1000;  // unknowns; chord corrector from there on, 0: never
  std::string linear_solver = "auto";   // auto, dense_lu or gmres (ContinuationOptions)
  int gmres_from = 5000;                // unknowns; auto picks gmres from there on (no operator)
  int matrix_free_from = 500;           // unknowns; auto picks matrix_free from there on
  // Factor from `unit` to rad/s.
  double to_rad_per_s() const;
};

// A tuned cyclic disk: nb sectors under engine order m (sectors = 1: no cyclic symmetry).
struct CyclicSpec {
  int sectors = 1;
  int engine_order = 0;
  bool enabled() const { return sectors > 1; }
  // Harmonic index h = mod(n m, nb) of temporal harmonic n (0 without cyclic symmetry).
  int harmonic_index(int n) const { return enabled() ? (n * engine_order) % sectors : 0; }
  // Nodal diameter excited by harmonic index h: h for h <= nb/2 (backward travelling wave),
  // nb - h above (forward travelling wave); h = 0 and h = nb/2 are standing (thesis §2.2).
  int nodal_diameter(int h) const { return 2 * h <= sectors ? h : sectors - h; }
  // '-' backward, '+' forward, ' ' standing (the thesis's Table 5.1 notation).
  char wave_direction(int h) const {
    if (h == 0 || 2 * h == sectors) return ' ';
    return 2 * h < sectors ? '-' : '+';
  }
};

// A mistuned disk (the scene's `mistuning` section on a cyclic scene): every blade's
// stiffness factor, the full disk built from the tuned sector (model/mistuned_disk.hpp). The
// scene read with it describes the whole disk: every node `name` of the sector becomes one per
// blade, `name@j` (j = 0..sectors-1, the DOF d of the sector's blade j numbered d * sectors +
// j), every contact `c` one per blade, `c@j`, joining blade j to blade j + its sector offset
// (modulo sectors), every excitation entry one per blade, delayed by j m / nb of a period
// (harmonic n's phase minus n m 2 pi j / nb), and `cyclic` is off (sectors = 1).
struct Scene;
struct MistuningSpec {
  int sectors = 0;       // nb of the tuned disk
  int engine_order = 0;  // m
  // Blade j's stiffness factor is 1 + deviations[j] (its blade part's stiffness, as the
  // provider defines it).
  std::vector<double> deviations;
  // Where the deviations came from: "given", or a random pattern's distribution.
  std::string source = "given";
  double sigma = 0;  // standard deviation of a random pattern
  long long seed = 0;
  std::vector<std::string> sector_nodes;     // the tuned sector's node names, scene order
  std::vector<std::string> sector_contacts;  // the tuned sector's contact names
  // The same scene without its `mistuning` section: the tuned sector, for the tuned disk's
  // response that the mistuned one is compared with (bound by bind_plugins with it).
  std::shared_ptr<Scene> tuned;
  // The name of node (or contact) `name` on blade j.
  static std::string on_blade(const std::string& name, int blade);
};

// Overrides of scene keys (`frichb run SCENE --set PATH=VALUE`, or a library caller's
// SceneInput::overrides): a scene-key path (below) and a value in YAML's flow syntax, typed by
// the schema of the key it sets like a value written in the file: a number, a boolean, a word,
// or a list (`[330, 400]`). A scalar value sets a scalar (or a key the scene did not write); a
// list value also replaces a list. They travel with the scene (Scene::overrides): every
// document read again from its file (a study's runs, a convergence study's settings) has them
// applied, and summary.json records them.
struct SceneOverride {
  std::string path;
  std::string value;  // YAML flow text
};

// Where a verb reads its scene from and what its caller changes in it: the options every
// scene-reading verb takes first. No process-wide setting changes how a scene is read.
struct SceneInput {
  std::filesystem::path file;
  std::vector<SceneOverride> overrides;  // applied in order to the document read from `file`
  // Load plugins from the folders the scene's plugin_paths names (loading a library runs its
  // code: off unless the user allows it, `--allow-scene-plugins`). Folders of the default
  // search path and FRICHB_PLUGIN_PATH are always allowed.
  bool allow_scene_plugins = false;
  // The scene's YAML (or JSON) text, when it does not come from a file (a Python dict): `file`
  // then only names it in messages and outputs, and its folder is the one the relative paths
  // the scene holds are taken from. Nothing is read from `file`.
  std::optional<std::string> text = std::nullopt;
};

// How the plots scale amplitudes: automatic is log where the plotted values span more than a
// decade, linear otherwise.
enum class AmplitudeAxis { automatic, linear, log };

struct OutputSpec {
  std::vector<std::string> response;      // node names
  std::vector<double> friction_loops_at;  // in the continuation unit
  std::vector<double> contact_states_at;  // in the continuation unit
  bool plots = true;
  AmplitudeAxis amplitude_axis = AmplitudeAxis::automatic;
  // contact_harmonics.csv: each contact's force and relative displacement harmonics at every
  // point (one extra contact evaluation per point).
  bool contact_forces = false;
  // response.csv's stable and largest_multiplier columns: the Floquet multipliers of every
  // point (model/stability.hpp).
  bool stability = false;
};

struct Scene {
  std::filesystem::path file;
  // How the scene was read (SceneInput): kept so that every re-reading applies the same
  // overrides and every binding the same plugin permission.
  std::vector<SceneOverride> overrides;
  bool allow_scene_plugins = false;
  // SceneInput::text, kept for every re-reading (null: the scene was read from `file`).
  std::shared_ptr<const std::string> text;
  std::string name, description;
  std::vector<std::filesystem::path> plugin_paths;  // resolved against the scene's folder
  StructureSpec structure;
  std::vector<ExcitationSpec> excitation;
  std::vector<ContactSpec> contacts;
  HarmonicBalanceSpec harmonic_balance;
  CyclicSpec cyclic;
  // Set when the scene's `mistuning` section made it a whole mistuned disk (see
  // MistuningSpec: `cyclic` is then off and the nodes, contacts and excitation are the disk's).
  std::optional<MistuningSpec> mistuning;
  ContinuationSpec continuation;
  OutputSpec output;
  YAML::Node root;
  nlohmann::json core_values;  // every core key with its default filled in
};

// Parses and validates the scene's own structure, `overrides` applied (and kept in
// Scene::overrides). Throws SceneError.
Scene load_scene(const std::filesystem::path& file,
                 const std::vector<SceneOverride>& overrides = {});
// The same on a document already parsed from `file` (marks give lines and columns in it).
// The scene keeps a handle to `document`: give each Scene its own document.
Scene load_scene(const YAML::Node& document, const std::filesystem::path& file);
// Parses `file` as YAML. Throws SceneError (missing file, a folder, malformed YAML).
YAML::Node load_scene_yaml(const std::filesystem::path& file);
// Parses `text` as a scene's YAML, `file` naming it in errors. Throws SceneError (malformed
// YAML, more than one document, duplicate keys).
YAML::Node parse_scene_yaml(const std::string& text, const std::filesystem::path& file);
// The plugin_paths of an input file (a scene, a loop input), each relative one taken from the
// file's folder. `kind` names the file in the error ("scene", "input"). Throws SceneError at
// plugin_paths[i] for a folder that does not exist.
std::vector<std::filesystem::path> resolve_plugin_paths(const std::vector<std::string>& listed,
                                                        YAML::Node root,
                                                        const std::filesystem::path& file,
                                                        const std::string& kind,
                                                        const YamlContext& ctx);

// Scene-key paths, as study sweeps and `--set` address numeric scalars: map keys joined by
// '.', a contact (any list entry with a `name:`) by its name, a list entry by its index as a
// key or in brackets: `contacts.shroud.params.mu`, `excitation.0.amplitude`,
// `harmonic_balance.max_harmonic`, `a.b[2]`. The last key of a map may be absent (a default
// the scene did not write). Implemented in scene_path.cpp.
//
// Sets the scalar at `path` in `document` to `value` (an integral value is written as an
// integer, any other as the shortest text that reads back as the same double: 0.1, 2.5e-05). Throws
// std::invalid_argument naming the part of the path that does not resolve, or saying that it
// addresses a map or a list.
void set_scene_value(YAML::Node document, const std::string& path, double value);
// The same checks without writing (`document` is left untouched).
void check_scene_path(const YAML::Node& document, const std::string& path);
// A value as set_scene_value writes it.
std::string format_scene_value(double x);

// Reads `PATH=VALUE`. Throws std::invalid_argument saying what is wrong with it (no '=', an
// empty side, a malformed path, a value that is not YAML, a map, or a number out of range).
SceneOverride parse_scene_override(const std::string& text);
// The value as JSON (numbers, booleans, text and lists), as summary.json records it.
nlohmann::json scene_override_json(const SceneOverride& o);
// Applies one override to `document`. Throws std::invalid_argument as set_scene_value.
void set_scene_override(YAML::Node document, const SceneOverride& o);
// load_scene_yaml with `overrides` applied. Throws SceneError naming the file and the
// override (`--set PATH`) whose path does not resolve.
YAML::Node load_scene_document(const std::filesystem::path& file,
                               const std::vector<SceneOverride>& overrides);

// A variant of a scene read so far: the document of `base`'s file read again with its
// overrides (for a study's run or a convergence setting to change keys of), and the scene of
// such a document, keeping `base`'s file, overrides and plugin permission. Throw as
// load_scene_document and load_scene.
YAML::Node reread_scene_document(const Scene& base);
Scene load_scene_variant(const YAML::Node& document, const Scene& base);

// Loads the plugins the scene names (and only those) and validates their params. A plugin
// found only in a folder of scene.plugin_paths is refused unless scene.allow_scene_plugins.
// Throws SceneError (bad params, with file:line:column) or PluginError (unknown plugin...).
void bind_plugins(Scene& scene, const Registry& registry);

// A scene bound to its plugins, with the registry that keeps them loaded (members destroyed
// scene first).
struct BoundScene {
  std::unique_ptr<Registry> registry;
  Scene scene;
};
// load_scene + bind_plugins on the default plugin search path and the scene's plugin_paths
// (loaded from only when input.allow_scene_plugins). Throws SceneError (file:line:column and
// key where known; any other failure while reading the input is reported as one, naming the
// file) or PluginError.
BoundScene load_bound_scene(const SceneInput& input);

// The validated scene, defaults filled in, for summary.json.
nlohmann::json scene_to_json(const Scene& scene);

// The core's section schemas, for the generated scene reference.
struct CoreSection {
  std::string path;  // e.g. "continuation.frequency"
  std::vector<frichb_param_spec> schema;
  std::string note;  // keys validated by hand, in prose
};
std::vector<CoreSection> core_schemas();

}  // namespace frichb::core
