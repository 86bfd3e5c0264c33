// libFuzzer target: scene parsing and schema validation on arbitrary bytes.
//
// The input is a scene file's text. It goes through the path of `frichb validate`: YAML
// parsing (a yaml-cpp error is turned into a SceneError as load_scene_yaml does), the core's
// section schemas (load_scene), the plugins' parameter schemas (bind_plugins, on a registry of
// the built plugin folder: a scene's plugin_paths are not searched, so that fuzzed input never
// makes the target scan or dlopen arbitrary files), and, when the scene has a `study:` section,
// load_study and prepare_study_runs (which re-reads the scene from its file and instantiates
// every contact law of every run).
//
// Expected outcomes are success, SceneError and PluginError: the documented input errors.
// Anything else escaping (another exception, a crash, a sanitizer report, a hang) is a finding.
#include <spdlog/spdlog.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <typeinfo>

#include "frichb/core/commands/study.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace {

namespace fs = std::filesystem;
using namespace frichb::core;

// prepare_study_runs binds every run to plugins; studies of more runs than this are only
// checked by load_study (a legitimate study of thousands of runs would exceed the per-input
// time limit without exercising anything new).
constexpr std::size_t kMaxPreparedRuns = 64;

fs::path g_scene_file;
std::unique_ptr<Registry> g_registry;

fs::path plugin_folder() {
  if (const char* dir = std::getenv("FRICHB_FUZZ_PLUGIN_DIR")) return dir;
  return FRICHB_PLUGIN_DIR;
}

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scene: FINDING: %s: %s\n", what, detail.c_str());
  std::fflush(stderr);
  std::abort();
}

std::size_t run_count(const StudySpec& study) {
  std::size_t total = study.zip ? 0 : 1;
  for (const auto& sweep : study.sweeps) {
    const std::size_t n = sweep.values.size();
    if (study.zip) {
      total = n;
    } else {
      if (n != 0 && total > kMaxPreparedRuns / n) return kMaxPreparedRuns + 1;
      total *= n;
    }
  }
  return total;
}

void check_scene(const std::string& text) {
  YAML::Node document;
  try {
    document = YAML::Load(text);
  } catch (const YAML::Exception&) {
    return;  // load_scene_yaml reports it as a SceneError: "malformed YAML"
  }
  Scene scene = load_scene(document, g_scene_file);
  bind_plugins(scene, *g_registry);
  if (!scene.root["study"]) return;
  const StudySpec study = load_study(scene);
  if (run_count(study) > kMaxPreparedRuns) return;
  {
    // prepare_study_runs re-reads the scene from its file.
    std::ofstream out(g_scene_file, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (!out) finding("setup", "cannot write " + g_scene_file.string());
  }
  prepare_study_runs(scene, study, *g_registry);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  spdlog::set_level(spdlog::level::off);
  const fs::path dir = fs::temp_directory_path() /
                       ("frichb-fuzz-scene-" + std::to_string(static_cast<long long>(getpid())));
  fs::create_directories(dir);
  g_scene_file = dir / "scene.yaml";
  std::atexit([] {
    std::error_code ec;
    fs::remove_all(g_scene_file.parent_path(), ec);
  });
  try {
    g_registry = std::make_unique<Registry>(std::vector<fs::path>{plugin_folder()});
  } catch (const std::exception& e) {
    finding("setup", std::string("plugin registry: ") + e.what());
  }
  if (g_registry->names().empty())
    finding("setup", "no plugins in " + plugin_folder().string() +
                         " (set FRICHB_FUZZ_PLUGIN_DIR or build the plugins)");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    check_scene(text);
  } catch (const SceneError&) {
  } catch (const PluginError&) {
  } catch (const std::exception& e) {
    finding(typeid(e).name(), e.what());
  } catch (...) {
    finding("exception", "not derived from std::exception");
  }
  return 0;
}
