// Plugin discovery and loading (Boost.DLL), and the host-side handles of plugin instances.
//
// Discovery reads only symbol tables (boost::dll::library_info): a plugin's name is the
// suffix of its exported marker symbol `frichb_plugin_name__<name>`. Nothing of a library
// runs until a scene names it and load() is called; load() then checks the descriptor's
// ABI version and kind. Errors are PluginError with a message fit for the user.
#pragma once

#include <complex>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/plugin/abi.h"

namespace boost::dll {
class shared_library;
}

namespace frichb::core {

class PluginError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

const char* to_string(frichb_plugin_kind kind);

// A loaded plugin library. The library stays loaded while any LoadedPlugin or instance made
// from it lives (instances hold a shared_ptr to it).
class LoadedPlugin {
 public:
  LoadedPlugin(std::shared_ptr<boost::dll::shared_library> library,
               const frichb_plugin_descriptor* descriptor, std::filesystem::path file);
  const frichb_plugin_descriptor& descriptor() const { return *descriptor_; }
  const std::filesystem::path& file() const { return file_; }
  std::string name() const { return descriptor_->name; }
  frichb_plugin_kind kind() const { return static_cast<frichb_plugin_kind>(descriptor_->kind); }
  std::span<const frichb_param_spec> schema() const {
    return {descriptor_->params, descriptor_->n_params};
  }

 private:
  std::shared_ptr<boost::dll::shared_library> library_;
  const frichb_plugin_descriptor* descriptor_;
  std::filesystem::path file_;
};

// Loads one plugin file and checks its descriptor (ABI major equal, minor not newer, struct
// size, kind consistent with its function table). Throws PluginError naming the file.
std::shared_ptr<const LoadedPlugin> load_plugin_file(const std::filesystem::path& file);

// The file of the binary that holds the FricHB core: the core is a static library, so this is
// the program or the shared module (a Python extension, a plugin of another application) it
// is linked into, not necessarily the running program. Sets `ec` when it cannot be found.
std::filesystem::path core_binary_location(std::error_code& ec);

class Registry {
 public:
  // Search path in priority order: <dir>/../lib/frichb/plugins, <dir> the folder of
  // core_binary_location() (the frichb program, or the program or module linking the core;
  // the build tree and an installed prefix alike), the configured install prefix, each entry
  // of $FRICHB_PLUGIN_PATH (':'-separated), then `extra`.
  static std::vector<std::filesystem::path> default_search_path(
      const std::vector<std::filesystem::path>& extra = {});

  // Discovers plugins in `search_path` (missing folders are skipped). Two different files
  // that declare the same name are fatal: PluginError naming both files.
  explicit Registry(std::vector<std::filesystem::path> search_path);

  const std::vector<std::filesystem::path>& search_path() const { return search_path_; }
  // Sorted names of all discovered plugins.
  std::vector<std::string> names() const;
  std::filesystem::path file_of(const std::string& name) const;
  bool contains(const std::string& name) const { return files_.count(name) != 0; }

  // Loads the plugin `name` (once; later calls return the same object). Unknown names list
  // the valid ones and the closest match; a plugin of another kind than `expected` is
  // refused.
  std::shared_ptr<const LoadedPlugin> load(const std::string& name,
                                           frichb_plugin_kind expected) const;
  std::shared_ptr<const LoadedPlugin> load_any(const std::string& name) const;

 private:
  std::vector<std::filesystem::path> search_path_;
  std::map<std::string, std::filesystem::path> files_;
  mutable std::map<std::string, std::shared_ptr<const LoadedPlugin>> loaded_;
};

// One contact-law instance made by a plugin from validated parameters. step() is const and
// thread-safe (the plugin contract requires it).
class ContactLawInstance {
 public:
  ContactLawInstance(std::shared_ptr<const LoadedPlugin> plugin, const ParamValues& params);
  ~ContactLawInstance();
  ContactLawInstance(const ContactLawInstance&) = delete;
  ContactLawInstance& operator=(const ContactLawInstance&) = delete;

  const frichb_contact_law_traits& traits() const { return traits_; }
  const LoadedPlugin& plugin() const { return *plugin_; }
  void initial_state(double* state) const;
  // Returns false and fills `error` when the plugin reports a failure.
  bool step(const double* state_prev, const double* u_prev, const double* u_now, double* force_now,
            double* state_now, const frichb_step_tangents* tangents, std::string* error) const;
  // ABI 1.3: true when the law steps along the motion between samples (step_along).
  bool traces_motion() const { return traces_motion_; }
  // The step along the motion (frichb_contact_law_api::step_along); only when traces_motion().
  bool step_along(const double* state_prev, const double* u_prev, const double* u_now,
                  const frichb_step_motion& motion, double* force_now, double* state_now,
                  const frichb_step_tangents* tangents,
                  const frichb_motion_tangents* motion_tangents, frichb_force_kinks* kinks,
                  std::string* error) const;

 private:
  std::shared_ptr<const LoadedPlugin> plugin_;
  const frichb_contact_law_api* api_;
  void* instance_ = nullptr;
  frichb_contact_law_traits traits_{};
  bool traces_motion_ = false;
};

// One structure-provider instance. Not thread-safe.
// A structure as the engine reads it: DOFs, sectors and the modal basis of a harmonic index
// at the DOFs a scene keeps (frichb_structure_api's contract). A provider plugin's instance
// (StructureInstance) is one; a model the host builds on one (a mistuned disk,
// model/mistuned_disk.hpp) is another. Not thread-safe.
class StructureModel {
 public:
  virtual ~StructureModel() = default;
  // What messages call it: the provider's name.
  virtual std::string name() const = 0;
  virtual std::size_t dof_count() const = 0;
  // Sectors of a cyclic sector model; 1 for a plain structure.
  virtual std::size_t sector_count() const = 0;
  // The pointers stay valid until the next call or the model's destruction. Throws
  // PluginError (or std::invalid_argument) with the reason on failure.
  virtual frichb_modal_basis modal_basis(int harmonic_index,
                                         std::span<const std::size_t> kept_dofs) = 0;
};

class StructureInstance final : public StructureModel {
 public:
  StructureInstance(std::shared_ptr<const LoadedPlugin> plugin, const ParamValues& params);
  ~StructureInstance() override;
  StructureInstance(const StructureInstance&) = delete;
  StructureInstance& operator=(const StructureInstance&) = delete;

  const LoadedPlugin& plugin() const { return *plugin_; }
  std::string name() const override;
  std::size_t dof_count() const override;
  // Sectors of a cyclic sector model; 1 for a plain structure (and for ABI 1.0 plugins).
  std::size_t sector_count() const override;
  // Throws PluginError with the plugin's message on failure.
  frichb_modal_basis modal_basis(int harmonic_index,
                                 std::span<const std::size_t> kept_dofs) override;
  // Whether the plugin's table has blade_stiffness (ABI 1.4); it may still refuse to answer.
  bool offers_blade_stiffness() const;
  // frichb_structure_api.blade_stiffness: Phi_h1^H K_b Phi_h2 (or Phi_h1^T K_b Phi_h2),
  // `rows` x `cols` (the two indices' mode counts), row-major, 1/s^2. Throws PluginError
  // with the plugin's message (no mistunable part, or an older plugin).
  std::vector<std::complex<double>> blade_stiffness(int h1, int h2, bool conjugate_first,
                                                    std::size_t rows, std::size_t cols);

 private:
  std::shared_ptr<const LoadedPlugin> plugin_;
  const frichb_structure_api* api_;
  void* instance_ = nullptr;
};

// Plugin folders that an input file names (a scene's or a loop input's `plugin_paths`) are
// not trusted: loading a library runs its code, so a plugin found only there is loaded when
// the caller allows it (`allowed`: `frichb --allow-scene-plugins`, SceneInput's
// allow_scene_plugins) or when the folder is on the default search path (FRICHB_PLUGIN_PATH).
// Throws PluginError naming `plugin_file` and the folder when the file lies in one of
// `input_folders` and loading from there is not allowed.
void check_plugin_allowed(const std::filesystem::path& plugin_file,
                          const std::vector<std::filesystem::path>& input_folders, bool allowed);

}  // namespace frichb::core
