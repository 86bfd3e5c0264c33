// Helpers shared by the test suites: plugins through the real loader, temporary scenes.
#pragma once

#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "frichb/core/registry.hpp"
#include "frichb/core/schema.hpp"

namespace frichb::test {

inline const core::Registry& built_plugins() {
  static const core::Registry registry({FRICHB_PLUGIN_DIR});
  return registry;
}

// A contact law made by its plugin from YAML params, e.g. "{kt: 1, mu: 0.3, normal_load: 2}".
struct LawHandle {
  core::ParamValues values;
  std::unique_ptr<core::ContactLawInstance> law;
};
inline LawHandle make_law(const std::string& name, const std::string& params_yaml) {
  auto plugin = built_plugins().load(name, FRICHB_KIND_CONTACT_LAW);
  LawHandle h;
  h.values = core::validate_params(YAML::Load(params_yaml), plugin->schema(), "params",
                                   core::YamlContext{"<test>"});
  h.law = std::make_unique<core::ContactLawInstance>(plugin, h.values);
  return h;
}

// A fresh temporary folder, removed with the object.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("frichb_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = path_ / name;
    std::ofstream(p) << text;
    return p;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace frichb::test
