// A lumped tuned bladed disk of 6 sectors under engine order 2 by default (per sector a disk mass
// of 0.5 kg on 2e6 N/m and a blade of 0.1 kg on 4e5 N/m; neighbouring disks coupled by 1e5 N/m),
// with a contact between neighbouring blades (a shroud), in two forms: one sector with cyclic
// symmetry, and the whole disk assembled (every sector, a contact between each pair of
// neighbouring blades, the engine-order excitation as phase-shifted forces on every blade).
// The two describe the same structure; tests compare what the cyclic reduction computes
// against the plain computation on the whole disk.
#pragma once

#include <complex>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "frichb/core/model/harmonic_balance.hpp"

namespace frichb::test {

inline constexpr int kDiskSectors = 6;

struct DiskOptions {
  int engine_order = 2;
  std::string law = "jenkins_1d";
  std::string params = "{kt: 1.0e5, mu: 0.5, normal_load: 5.0}";
  std::string harmonics = "[0, 1, 2, 3]";
  int samples = 96;        // a multiple of the sectors: sector delays are whole samples
  double amplitude = 2.0;  // N on each blade
  double from_hz = 200.0, to_hz = 400.0;
  bool stability = false;
  // Blade j's disk-to-blade spring times 1 + blade_deviations[j] (the whole disk only; empty:
  // tuned). The cyclic scene names the blade (`blade_dofs: [1]`) so that a `mistuning`
  // section can give the same disk.
  std::vector<double> blade_deviations = {};
};

inline std::string harmonic_balance_and_rest(const DiskOptions& o, const std::string& response) {
  std::ostringstream s;
  s << "harmonic_balance: {harmonics: " << o.harmonics << ", samples_per_period: " << o.samples
    << "}\ncontinuation: {frequency: {from: " << o.from_hz << ", to: " << o.to_hz
    << "}}\noutput: {response: " << response << (o.stability ? ", stability: true" : "") << "}\n";
  return s.str();
}

inline std::string cyclic_disk_scene(const DiskOptions& o = {}) {
  std::ostringstream s;
  s << "cyclic: {sectors: " << kDiskSectors << ", engine_order: " << o.engine_order << "}\n"
    << "structure:\n  provider: lumped_cyclic\n  params:\n    sectors: " << kDiskSectors << "\n"
    << "    masses: [0.5, 0.1]\n"
    << "    springs: [{between: [ground, 0], k: 2.0e6}, {between: [0, 1], k: 4.0e5}]\n"
    << "    coupling: [{between: [0, 0], k: 1.0e5}]\n    modal_damping: [0.01]\n"
    << "    blade_dofs: [1]\n"
    << "  dofs: {disk: 0, blade: 1}\n"
    << "excitation: [{dof: blade, amplitude: " << o.amplitude << "}]\n"
    << "contacts:\n  - name: shroud\n    law: " << o.law << "\n"
    << "    between: [{node: blade, sector: 0}, {node: blade, sector: 1}]\n"
    << "    frame: {tangent1: [1.0]}\n    params: " << o.params << "\n"
    << harmonic_balance_and_rest(o, "[blade, disk]");
  return s.str();
}

inline std::string full_disk_scene(const DiskOptions& o = {}) {
  std::ostringstream s;
  s << "structure:\n  provider: lumped\n  params:\n    masses: [";
  for (int k = 0; k < kDiskSectors; ++k) s << (k ? ", " : "") << "0.5, 0.1";
  s << "]\n    springs:\n";
  for (int k = 0; k < kDiskSectors; ++k) {
    const int disk = 2 * k, blade = 2 * k + 1, next_disk = 2 * ((k + 1) % kDiskSectors);
    s << "      - {between: [ground, " << disk << "], k: 2.0e6}\n"
      << "      - {between: [" << disk << ", " << blade
      << "], k: " << 4.0e5 * (o.blade_deviations.empty() ? 1.0 : 1.0 + o.blade_deviations[k])
      << "}\n"
      << "      - {between: [" << disk << ", " << next_disk << "], k: 1.0e5}\n";
  }
  s << "    modal_damping: [0.01]\n  dofs: {";
  for (int k = 0; k < kDiskSectors; ++k)
    s << (k ? ", " : "") << "disk" << k << ": " << 2 * k << ", blade" << k << ": " << 2 * k + 1;
  s << "}\nexcitation:\n";
  // Sector k is forced like the reference delayed by k Delta t: phase -k m 360 / nb degrees.
  for (int k = 0; k < kDiskSectors; ++k)
    s << "  - {dof: blade" << k << ", amplitude: " << o.amplitude
      << ", phase_deg: " << -360.0 * k * o.engine_order / kDiskSectors << "}\n";
  s << "contacts:\n";
  for (int k = 0; k < kDiskSectors; ++k)
    s << "  - {name: shroud" << k << ", law: " << o.law << ", between: [blade" << k << ", blade"
      << (k + 1) % kDiskSectors << "], frame: {tangent1: [1.0]}, params: " << o.params << "}\n";
  s << harmonic_balance_and_rest(o, "[blade0, disk0]");
  return s.str();
}

// The whole disk's unknowns [U; w] of a solution y of the cyclic model: contact k is the
// reference contact delayed by k Delta t (harmonic n's complex amplitude times
// e^{-i n m phi k}).
inline Eigen::VectorXd full_disk_unknowns(const core::HarmonicLayout& layout,
                                          const Eigen::VectorXd& y,
                                          int engine_order = DiskOptions{}.engine_order) {
  const Eigen::Index c = layout.coefficient_count(), n = y.size() - 1;
  const double phi = 2 * std::numbers::pi / kDiskSectors;
  Eigen::VectorXd out(kDiskSectors * n + 1);
  for (int k = 0; k < kDiskSectors; ++k)
    for (Eigen::Index block = 0; block < n / c; ++block)
      for (std::size_t h = 0; h < layout.harmonics().size(); ++h) {
        const int nh = layout.harmonics()[h];
        const Eigen::Index ci = block * c + layout.cos_index(h),
                           si = block * c + layout.sin_index(h);
        const std::complex<double> x(y(ci), nh ? -y(si) : 0.0);
        const std::complex<double> shifted = x * std::polar(1.0, -nh * engine_order * phi * k);
        out(k * n + ci) = shifted.real();
        if (nh) out(k * n + si) = -shifted.imag();
      }
  out(kDiskSectors * n) = y(n);
  return out;
}

}  // namespace frichb::test
