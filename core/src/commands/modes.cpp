#include "frichb/core/commands/modes.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <numbers>

#include "frichb/core/model/mistuned_disk.hpp"
#include "frichb/core/plugin_host/registry.hpp"

namespace frichb::core {

ModesResult compute_modes(const ModesOptions& options) {
  const BoundScene bound = load_bound_scene(options.scene);
  const Scene& scene = bound.scene;
  const auto instance = instantiate_structure(scene);
  StructureModel& structure = *instance;
  ModesResult result;
  result.scene_file = scene.file;
  result.sectors = static_cast<int>(structure.sector_count());
  result.engine_order = scene.cyclic.engine_order;
  result.plots = scene.output.plots;
  std::vector<std::size_t> kept;
  for (const auto& node : scene.structure.nodes)
    kept.insert(kept.end(), node.dofs.begin(), node.dofs.end());
  CyclicSpec cyclic = scene.cyclic;
  cyclic.sectors = result.sectors;
  // Harmonic indices h and sectors - h have complex-conjugate sector matrices, hence the
  // same natural frequencies: only h = 0..sectors/2 (one per nodal diameter) are solved.
  auto& by_nd = result.frequencies_hz;
  by_nd.resize(static_cast<std::size_t>(result.sectors / 2) + 1);
  const auto started = std::chrono::steady_clock::now();
  for (int h = 0; 2 * h <= result.sectors; ++h) {
    const frichb_modal_basis b = structure.modal_basis(h, kept);
    for (std::size_t r = 0; r < b.n_modes; ++r)
      by_nd[static_cast<std::size_t>(h)].push_back(b.natural_frequencies[r] /
                                                   (2 * std::numbers::pi));
    spdlog::info("  nodal diameter {} of {}: {} modes ({:.1f} s)", h, result.sectors / 2, b.n_modes,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  }
  for (int h = 0; h < result.sectors; ++h) {
    const int nd = cyclic.nodal_diameter(h);
    const auto& frequencies = by_nd[static_cast<std::size_t>(nd)];
    const char dir = cyclic.wave_direction(h);
    for (std::size_t r = 0; r < frequencies.size(); ++r)
      result.modes.push_back(
          {h, nd, dir == '-' ? -1 : (dir == '+' ? 1 : 0), static_cast<int>(r + 1), frequencies[r]});
  }
  result.families = by_nd.front().size();
  for (const auto& f : by_nd) result.families = std::min(result.families, f.size());

  if (options.rpm_low > 0) result.speeds_rpm.push_back(options.rpm_low);
  if (options.rpm_high > options.rpm_low) result.speeds_rpm.push_back(options.rpm_high);
  if (cyclic.enabled())
    // Temporal harmonic n of engine order m at speed S excites n m S / 60 Hz on the nodal
    // diameter of h = mod(n m, nb): the zig-zag line of the ZZENF diagram.
    for (double rpm : result.speeds_rpm)
      for (int n : scene.harmonic_balance.harmonics) {
        if (n == 0) continue;
        const int h = cyclic.harmonic_index(n);
        result.excitation.push_back(
            {rpm, n, h, cyclic.nodal_diameter(h), n * scene.cyclic.engine_order * rpm / 60.0});
      }
  spdlog::info("{}: {} harmonic indices, {} modes", scene.file.string(), result.sectors,
               result.modes.size());
  return result;
}

}  // namespace frichb::core
