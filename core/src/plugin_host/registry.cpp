#include "frichb/core/plugin_host/registry.hpp"

#include <dlfcn.h>
#include <link.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <boost/dll/library_info.hpp>
#include <boost/dll/runtime_symbol_info.hpp>
#include <boost/dll/shared_library.hpp>
#include <cstddef>
#include <cstdlib>
#include <set>
#include <sstream>

namespace frichb::core {

namespace fs = std::filesystem;

const char* to_string(frichb_plugin_kind kind) {
  switch (kind) {
    case FRICHB_KIND_CONTACT_LAW:
      return "contact_law";
    case FRICHB_KIND_STRUCTURE:
      return "structure";
  }
  return "unknown";
}

LoadedPlugin::LoadedPlugin(std::shared_ptr<boost::dll::shared_library> library,
                           const frichb_plugin_descriptor* descriptor, fs::path file)
    : library_(std::move(library)), descriptor_(descriptor), file_(std::move(file)) {}

std::shared_ptr<const LoadedPlugin> load_plugin_file(const fs::path& file) {
  auto library = std::make_shared<boost::dll::shared_library>();
  try {
    library->load(file, boost::dll::load_mode::rtld_lazy | boost::dll::load_mode::rtld_local);
  } catch (const std::exception& e) {
    throw PluginError("cannot load plugin " + file.string() + ": " + e.what());
  }
  if (!library->has(FRICHB_PLUGIN_ENTRY_SYMBOL))
    throw PluginError("plugin " + file.string() + " has no entry point '" +
                      FRICHB_PLUGIN_ENTRY_SYMBOL + "'");
  auto entry = library->get<const frichb_plugin_descriptor*()>(FRICHB_PLUGIN_ENTRY_SYMBOL);
  const frichb_plugin_descriptor* d = entry();
  if (!d) throw PluginError("plugin " + file.string() + " returned no descriptor");
  const std::string host =
      std::to_string(FRICHB_ABI_MAJOR) + "." + std::to_string(FRICHB_ABI_MINOR);
  const std::string theirs = std::to_string(d->abi_major) + "." + std::to_string(d->abi_minor);
  if (d->abi_major != FRICHB_ABI_MAJOR || d->abi_minor > FRICHB_ABI_MINOR)
    throw PluginError("plugin " + file.string() + " was built against plugin ABI " + theirs +
                      " but this frichb has ABI " + host + "; rebuild the plugin against this SDK");
  if (d->struct_size < sizeof(frichb_plugin_descriptor))
    throw PluginError("plugin " + file.string() + " has a truncated descriptor");
  const bool law = d->kind == FRICHB_KIND_CONTACT_LAW && d->contact_law != nullptr;
  const bool structure = d->kind == FRICHB_KIND_STRUCTURE && d->structure != nullptr;
  if (!law && !structure)
    throw PluginError("plugin " + file.string() + " declares kind " + std::to_string(d->kind) +
                      " without the matching function table");
  spdlog::debug("loaded plugin '{}' {} ({}) from {}", d->name, d->version, d->build_tag,
                file.string());
  return std::make_shared<LoadedPlugin>(std::move(library), d, file);
}

namespace {

// Anchors the lookup of the binary that holds this code.
const char core_binary_anchor = 0;

}  // namespace

fs::path core_binary_location(std::error_code& ec) {
  ec.clear();
  Dl_info info{};
  link_map* map = nullptr;
  if (dladdr1(&core_binary_anchor, &info, reinterpret_cast<void**>(&map), RTLD_DL_LINKMAP) == 0 ||
      map == nullptr) {
    ec = std::make_error_code(std::errc::bad_address);
    return {};
  }
  // The main program's link map has no name (and dladdr would give argv[0], which is not a
  // path when the program was found on PATH): its file is /proc/self/exe.
  if (map->l_name == nullptr || map->l_name[0] == '\0') return boost::dll::program_location(ec);
  return fs::absolute(fs::path(map->l_name), ec);
}

std::vector<fs::path> Registry::default_search_path(const std::vector<fs::path>& extra) {
  std::vector<fs::path> path;
  std::error_code ec;
  const fs::path binary = core_binary_location(ec);
  if (!ec && !binary.empty())
    path.push_back(binary.parent_path().parent_path() / FRICHB_PLUGIN_SUBDIR);
  path.push_back(fs::path(FRICHB_INSTALL_PREFIX) / FRICHB_PLUGIN_SUBDIR);
  if (const char* env = std::getenv("FRICHB_PLUGIN_PATH")) {
    std::stringstream ss(env);
    std::string item;
    while (std::getline(ss, item, ':'))
      if (!item.empty()) path.emplace_back(item);
  }
  path.insert(path.end(), extra.begin(), extra.end());
  return path;
}

Registry::Registry(std::vector<fs::path> search_path) : search_path_(std::move(search_path)) {
  const std::string marker = FRICHB_PLUGIN_NAME_MARKER_PREFIX;
  std::set<fs::path> seen;
  for (const auto& dir : search_path_) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> candidates;
    for (const auto& entry : fs::directory_iterator(dir, ec))
      if (entry.is_regular_file() && entry.path().extension() == ".so")
        candidates.push_back(entry.path());
    std::sort(candidates.begin(), candidates.end());
    for (const auto& file : candidates) {
      const fs::path canonical = fs::weakly_canonical(file, ec);
      if (!seen.insert(canonical).second) continue;
      std::vector<std::string> symbols;
      try {
        boost::dll::library_info info(file, false);
        symbols = info.symbols();
      } catch (const std::exception& e) {
        spdlog::debug("skipping {}: {}", file.string(), e.what());
        continue;
      }
      for (const auto& s : symbols) {
        if (s.rfind(marker, 0) != 0) continue;
        const std::string name = s.substr(marker.size());
        auto [it, inserted] = files_.emplace(name, canonical);
        if (!inserted && it->second != canonical)
          throw PluginError("two plugins are named '" + name + "': " + it->second.string() +
                            " and " + canonical.string() + "; remove one from the search path");
      }
    }
  }
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> out;
  for (const auto& [name, file] : files_) out.push_back(name);
  return out;
}

fs::path Registry::file_of(const std::string& name) const {
  auto it = files_.find(name);
  return it == files_.end() ? fs::path() : it->second;
}

std::shared_ptr<const LoadedPlugin> Registry::load_any(const std::string& name) const {
  if (auto it = loaded_.find(name); it != loaded_.end()) return it->second;
  auto it = files_.find(name);
  if (it == files_.end()) {
    const auto valid = names();
    std::string list;
    for (const auto& n : valid) list += (list.empty() ? "" : ", ") + n;
    const std::string best = closest_match(name, valid);
    std::string search;
    for (const auto& p : search_path_) search += "\n  " + p.string();
    throw PluginError("unknown plugin '" + name + "'" +
                      (best.empty() ? "" : " (did you mean '" + best + "'?)") +
                      "; available: " + (list.empty() ? "none" : list) + "; searched:" + search);
  }
  auto plugin = load_plugin_file(it->second);
  if (plugin->name() != name)
    throw PluginError("plugin file " + it->second.string() + " marks name '" + name +
                      "' but its descriptor says '" + plugin->name() + "'");
  loaded_[name] = plugin;
  return plugin;
}

std::shared_ptr<const LoadedPlugin> Registry::load(const std::string& name,
                                                   frichb_plugin_kind expected) const {
  auto plugin = load_any(name);
  if (plugin->kind() != expected)
    throw PluginError("plugin '" + name + "' is a " + to_string(plugin->kind()) + ", not a " +
                      to_string(expected));
  return plugin;
}

namespace {
constexpr std::size_t kMessageCapacity = 1024;
}

ContactLawInstance::ContactLawInstance(std::shared_ptr<const LoadedPlugin> plugin,
                                       const ParamValues& params)
    : plugin_(std::move(plugin)), api_(plugin_->descriptor().contact_law) {
  char message[kMessageCapacity] = {0};
  if (api_->create(params.data(), params.size(), &instance_, message, kMessageCapacity) !=
          FRICHB_OK ||
      !instance_)
    throw PluginError("contact law '" + plugin_->name() + "' refused its parameters: " + message);
  traits_.struct_size = sizeof(traits_);
  api_->traits(instance_, &traits_);
  if (traits_.tangential_dimensions < 0 || traits_.tangential_dimensions > 2 ||
      traits_.state_size < 0) {
    api_->destroy(instance_);  // the destructor does not run for a throwing constructor
    throw PluginError("contact law '" + plugin_->name() + "' reports invalid traits");
  }
  // A law steps along the motion when its traits say so and its table has the entry, and it
  // was built for ABI 1.3 or later (the layout of frichb_force_kinks that step_along uses).
  const bool traits_cover =
      traits_.struct_size >=
      offsetof(frichb_contact_law_traits, traces_motion) + sizeof(traits_.traces_motion);
  const bool api_covers =
      api_->struct_size >= offsetof(frichb_contact_law_api, step_along) + sizeof(api_->step_along);
  const bool kinks_layout = plugin_->descriptor().abi_minor >= 3;
  traces_motion_ = traits_cover && api_covers && kinks_layout && traits_.traces_motion != 0 &&
                   api_->step_along != nullptr;
  if (!traits_cover) traits_.traces_motion = 0;
}

ContactLawInstance::~ContactLawInstance() {
  if (instance_) api_->destroy(instance_);
}

void ContactLawInstance::initial_state(double* state) const {
  api_->initial_state(instance_, state);
}

bool ContactLawInstance::step(const double* state_prev, const double* u_prev, const double* u_now,
                              double* force_now, double* state_now,
                              const frichb_step_tangents* tangents, std::string* error) const {
  // Called once per time sample: only the first byte is cleared, not the whole buffer.
  char message[kMessageCapacity];
  message[0] = '\0';
  if (api_->step(instance_, state_prev, u_prev, u_now, force_now, state_now, tangents, message,
                 kMessageCapacity) == FRICHB_OK)
    return true;
  if (error) *error = "contact law '" + plugin_->name() + "': " + message;
  return false;
}

bool ContactLawInstance::step_along(const double* state_prev, const double* u_prev,
                                    const double* u_now, const frichb_step_motion& motion,
                                    double* force_now, double* state_now,
                                    const frichb_step_tangents* tangents,
                                    const frichb_motion_tangents* motion_tangents,
                                    frichb_force_kinks* kinks, std::string* error) const {
  char message[kMessageCapacity];
  message[0] = '\0';
  if (api_->step_along(instance_, state_prev, u_prev, u_now, &motion, force_now, state_now,
                       tangents, motion_tangents, kinks, message, kMessageCapacity) == FRICHB_OK)
    return true;
  if (error) *error = "contact law '" + plugin_->name() + "': " + message;
  return false;
}

StructureInstance::StructureInstance(std::shared_ptr<const LoadedPlugin> plugin,
                                     const ParamValues& params)
    : plugin_(std::move(plugin)), api_(plugin_->descriptor().structure) {
  char message[kMessageCapacity] = {0};
  if (api_->create(params.data(), params.size(), &instance_, message, kMessageCapacity) !=
          FRICHB_OK ||
      !instance_)
    throw PluginError("structure '" + plugin_->name() + "' refused its parameters: " + message);
}

StructureInstance::~StructureInstance() {
  if (instance_) api_->destroy(instance_);
}

std::string StructureInstance::name() const {
  return plugin_->name();
}

std::size_t StructureInstance::dof_count() const {
  return api_->dof_count(instance_);
}

std::size_t StructureInstance::sector_count() const {
  // sector_count came with ABI 1.1: older plugins' tables end before it.
  const std::size_t needed =
      offsetof(frichb_structure_api, sector_count) + sizeof(api_->sector_count);
  if (api_->struct_size < needed || !api_->sector_count) return 1;
  return api_->sector_count(instance_);
}

frichb_modal_basis StructureInstance::modal_basis(int harmonic_index,
                                                  std::span<const std::size_t> kept_dofs) {
  char message[kMessageCapacity] = {0};
  frichb_modal_basis basis{};
  basis.struct_size = sizeof(basis);
  if (api_->modal_basis(instance_, harmonic_index, kept_dofs.data(), kept_dofs.size(), &basis,
                        message, kMessageCapacity) != FRICHB_OK)
    throw PluginError("structure '" + plugin_->name() + "' failed on harmonic index " +
                      std::to_string(harmonic_index) + ": " + message);
  return basis;
}

bool StructureInstance::offers_blade_stiffness() const {
  const std::size_t needed =
      offsetof(frichb_structure_api, blade_stiffness) + sizeof(api_->blade_stiffness);
  return api_->struct_size >= needed && api_->blade_stiffness != nullptr;
}

std::vector<std::complex<double>> StructureInstance::blade_stiffness(int h1, int h2,
                                                                     bool conjugate_first,
                                                                     std::size_t rows,
                                                                     std::size_t cols) {
  if (!offers_blade_stiffness())
    throw PluginError("structure '" + plugin_->name() +
                      "' cannot be mistuned: it gives no blade stiffness (plugin ABI 1.4)");
  std::vector<double> re(rows * cols), im(rows * cols);
  char message[kMessageCapacity] = {0};
  if (api_->blade_stiffness(instance_, h1, h2, conjugate_first ? 1 : 0, rows, cols, re.data(),
                            im.data(), message, kMessageCapacity) != FRICHB_OK)
    throw PluginError("structure '" + plugin_->name() + "' cannot be mistuned: " + message);
  std::vector<std::complex<double>> out(rows * cols);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {re[i], im[i]};
  return out;
}

void check_plugin_allowed(const fs::path& plugin_file, const std::vector<fs::path>& input_folders,
                          bool allowed) {
  if (allowed || plugin_file.empty() || input_folders.empty()) return;
  std::error_code ec;
  const fs::path folder = fs::weakly_canonical(plugin_file, ec).parent_path();
  // Folders of the default search path (the program's own, the install prefix and
  // FRICHB_PLUGIN_PATH) are the user's choice: trusted even when a scene names them too.
  for (const auto& trusted : Registry::default_search_path())
    if (fs::weakly_canonical(trusted, ec) == folder) return;
  for (const auto& input : input_folders)
    if (fs::weakly_canonical(input, ec) == folder)
      throw PluginError("would load " + plugin_file.string() +
                        " from the input's plugin_paths folder " + input.string() +
                        ": loading a library runs its code, so plugins from folders that an "
                        "input names are loaded only with --allow-scene-plugins, or when the "
                        "folder is listed in FRICHB_PLUGIN_PATH");
}

}  // namespace frichb::core
