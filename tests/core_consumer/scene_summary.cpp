// Loads a scene with the installed FricHB core, binds its plugins from the default search
// path and prepares the run (structure, harmonic-balance model, continuation setup), then
// prints what it holds: "<name>: structure <provider>, DOFs <n>, contacts <n> (<law>, ...)".
// Then runs the `frichb run` verb in memory (run_scene: nothing is written) and prints each
// peak: "peak of <node>: <amplitude> m at <frequency> rad/s (<points> points, <termination>)".
// Exits 0 only when these are the quick-start scene's (one DOF, one jenkins_1d contact, the
// sweep completed with one peak on the blade).
#include <cstdio>
#include <exception>
#include <string>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: scene_summary SCENE.yaml\n");
    return 2;
  }
  try {
    frichb::core::Scene scene = frichb::core::load_scene(argv[1]);
    const frichb::core::Registry registry(frichb::core::Registry::default_search_path());
    frichb::core::bind_plugins(scene, registry);
    const frichb::core::PreparedRun run = frichb::core::prepare_run(scene);
    std::string laws;
    for (const auto& contact : scene.contacts)
      laws += (laws.empty() ? "" : ", ") + contact.plugin->name();
    // The run logs its progress (spdlog); the summary lines come after it, together.
    const frichb::core::RunResult result = frichb::core::run_scene({argv[1], {}, false});
    std::printf("%s: structure %s, DOFs %zu, contacts %zu (%s)\n", scene.name.c_str(),
                scene.structure.plugin->name().c_str(), run.structure->dof_count(),
                scene.contacts.size(), laws.c_str());
    for (const auto& peak : result.peaks)
      std::printf("peak of %s: %.6g m at %.6g rad/s (%zu points, %s)\n", peak.node.c_str(),
                  peak.amplitude_m, peak.omega_rad_s, result.summary.points.size(),
                  result.outcome.termination.c_str());
    // The quick-start scene: one DOF, one jenkins_1d contact, a sweep that completes with one
    // peak on the blade node.
    const bool expected = scene.structure.plugin->name() == "lumped" &&
                          run.structure->dof_count() == 1 && laws == "jenkins_1d" &&
                          result.outcome.status == 0 && result.outcome.termination == "completed" &&
                          result.peaks.size() == 1 && result.peaks.front().node == "blade" &&
                          result.peaks.front().amplitude_m > 0;
    if (!expected) std::fprintf(stderr, "scene_summary: not the quick-start scene's results\n");
    return expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "scene_summary: %s\n", e.what());
    return 1;
  }
}
