#include "frichb/core/commands/modes.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/report/failure.hpp"
#include "frichb/core/report/output.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/exit_codes.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

// Spacing of the labelled nodal diameters on the map's axis: every one up to 20, then
// every 2, 5 or 10 so that the labels (up to two or three digits) do not overlap.
int NodalDiameterTicStep(std::size_t nodal_diameters) {
  if (nodal_diameters <= 20) return 1;
  if (nodal_diameters <= 40) return 2;
  if (nodal_diameters <= 100) return 5;
  return 10;
}

}  // namespace

int run_modes(const ModesRequest& request) {
  const std::string file = request.scene_file.string();
  Scene scene;
  std::unique_ptr<Registry> registry;
  if (!load_bound_scene(request.scene_file, scene, registry)) return kExitInvalidInput;
  try {
    StructureInstance structure(scene.structure.plugin, scene.structure.values);
    const int sectors = static_cast<int>(structure.sector_count());
    std::vector<std::size_t> kept;
    for (const auto& node : scene.structure.nodes)
      kept.insert(kept.end(), node.dofs.begin(), node.dofs.end());
    CyclicSpec cyclic = scene.cyclic;
    cyclic.sectors = sectors;
    // Harmonic indices h and sectors - h have complex-conjugate sector matrices, hence the
    // same natural frequencies: only h = 0..sectors/2 (one per nodal diameter) are solved.
    std::vector<std::vector<double>> by_nd(static_cast<std::size_t>(sectors / 2 + 1));
    const auto started = std::chrono::steady_clock::now();
    for (int h = 0; 2 * h <= sectors; ++h) {
      const frichb_modal_basis b = structure.modal_basis(h, kept);
      for (std::size_t r = 0; r < b.n_modes; ++r)
        by_nd[static_cast<std::size_t>(h)].push_back(b.natural_frequencies[r] /
                                                     (2 * std::numbers::pi));
      spdlog::info(
          "  nodal diameter {} of {}: {} modes ({:.1f} s)", h, sectors / 2, b.n_modes,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    }
    std::vector<std::vector<double>> rows;
    for (int h = 0; h < sectors; ++h) {
      const auto& frequencies = by_nd[static_cast<std::size_t>(cyclic.nodal_diameter(h))];
      const char dir = cyclic.wave_direction(h);
      for (std::size_t r = 0; r < frequencies.size(); ++r)
        rows.push_back({static_cast<double>(h), static_cast<double>(cyclic.nodal_diameter(h)),
                        dir == '-' ? -1.0 : (dir == '+' ? 1.0 : 0.0), static_cast<double>(r + 1),
                        frequencies[r]});
    }
    fs::path out_dir = request.output_directory;
    if (out_dir.empty())
      out_dir = fs::path("out") / (request.scene_file.stem().string() + "-modes");
    StagedOutput out(out_dir,
                     {"modes.csv", "families.csv", "excitation.csv", "modes.gp", "modes.png"});
    write_csv(out.path("modes.csv"),
              {"harmonic_index", "nodal_diameter", "wave", "family", "frequency_hz"}, rows);
    std::vector<std::vector<double>> excitation;
    std::vector<double> speeds;
    if (request.rpm_low > 0) speeds.push_back(request.rpm_low);
    if (request.rpm_high > request.rpm_low) speeds.push_back(request.rpm_high);
    if (!speeds.empty() && cyclic.enabled()) {
      // Temporal harmonic n of engine order m at speed S excites n m S / 60 Hz on the nodal
      // diameter of h = mod(n m, nb): the zig-zag line of the ZZENF diagram.
      for (double rpm : speeds)
        for (int n : scene.harmonic_balance.harmonics) {
          if (n == 0) continue;
          const int h = cyclic.harmonic_index(n);
          excitation.push_back({rpm, static_cast<double>(n), static_cast<double>(h),
                                static_cast<double>(cyclic.nodal_diameter(h)),
                                n * scene.cyclic.engine_order * rpm / 60.0});
        }
      write_csv(out.path("excitation.csv"),
                {"rpm", "n", "harmonic_index", "nodal_diameter", "frequency_hz"}, excitation);
    }
    // One line per mode family over the nodal diameters 0..nb/2.
    std::size_t families = 0;
    for (const auto& f : by_nd) families = std::min(families ? families : f.size(), f.size());
    std::vector<std::string> fh = {"nodal_diameter"};
    for (std::size_t r = 0; r < families; ++r)
      fh.push_back("family" + std::to_string(r + 1) + "_hz");
    std::vector<std::vector<double>> frows;
    for (std::size_t nd = 0; nd < by_nd.size(); ++nd) {
      std::vector<double> row = {static_cast<double>(nd)};
      row.insert(row.end(), by_nd[nd].begin(), by_nd[nd].begin() + static_cast<long>(families));
      frows.push_back(std::move(row));
    }
    write_csv(out.path("families.csv"), fh, frows);
    if (scene.output.plots) {
      std::ostringstream gp;
      gp << "# gnuplot script written by frichb modes\n"
         << "set terminal pngcairo size 1000,700 noenhanced\nset output 'modes.png'\n"
         << "set datafile separator ','\nset grid\nset key outside right\n"
         << "set title 'nodal-diameter map (" << sectors << " sectors, engine order "
         << scene.cyclic.engine_order << ")'\n"
         << "set xlabel 'nodal diameter'\nset ylabel 'natural frequency [Hz]'\n"
         << "set xtics " << NodalDiameterTicStep(by_nd.size()) << "\nplot ";
      gp << "for [i=2:" << families + 1
         << "] 'families.csv' using 1:i with linespoints pt 7 title sprintf('family %d', i - 1)";
      for (std::size_t k = 0; k < speeds.size() && !excitation.empty(); ++k)
        gp << ", \\\n     'excitation.csv' using 4:($1 == " << speeds[k]
           << " ? $5 : 1/0) with linespoints dt 2 lw 2 lc rgb '" << (k ? "red" : "blue")
           << "' title 'EO " << scene.cyclic.engine_order << " at " << speeds[k]
           << " rpm', \\\n     'excitation.csv' using 4:($1 == " << speeds[k]
           << " ? $5 : 1/0):(sprintf('%d', $2)) with labels offset 1,0.5 notitle";
      gp << "\n";
      write_text(out.path("modes.gp"), gp.str());
      run_gnuplot(out.path("modes.gp"));
    }
    out.commit();
    spdlog::info("{}: {} harmonic indices, {} modes; wrote {}", file, sectors, rows.size(),
                 out_dir.string());
    return kExitOk;
  } catch (...) {
    return report_failure(file);
  }
}

}  // namespace frichb::core
